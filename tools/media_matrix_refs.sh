#!/usr/bin/env bash
# Mitsuba 3 `volpath` references of the media configuration matrix (tests/media_matrix/*.toml) into
# tests/reference/media/CASE.exr with CASE.json beside each (spp, time, the reference's own noise).
# Usage, from the repo root, after `pip install -r tools/requirements.txt`:
#     tools/media_matrix_refs.sh [SPP] [CASE ...]
set -euo pipefail
spp=${1:-4096}
shift || true
mkdir -p tests/reference/media
cases=("$@")
[ ${#cases[@]} -gt 0 ] || cases=($(ls tests/media_matrix/*.toml | xargs -n1 basename | sed 's/\.toml$//'))
for c in "${cases[@]}"; do
  echo "== $c"
  if [ "$c" = dense-point ]; then
    # A point light in dense fog: samples of unbounded variance, so 16× the samples in 16 passes.
    python3 tools/mitsuba_reference.py "tests/media_matrix/$c.toml" "tests/reference/media/$c.exr" \
      --spp $((spp * 16)) --passes 16
  else
    python3 tools/mitsuba_reference.py "tests/media_matrix/$c.toml" "tests/reference/media/$c.exr" --spp "$spp"
  fi
done
