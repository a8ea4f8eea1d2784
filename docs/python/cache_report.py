"""The irradiance cache of one render, reported: records made in each pass, lookups, records per lookup,
what shrank their radii, and the histogram of their radii in pixels; the record image beside it.

    python docs/python/cache_report.py [OUT_DIR]       (from the repository's root)
"""

import sys
from pathlib import Path

import matplotlib

matplotlib.use("Agg")
import matplotlib.pyplot as plt

import pmrender as pm

out = Path(sys.argv[1] if len(sys.argv) > 1 else "out/python")
out.mkdir(parents=True, exist_ok=True)

scene = pm.load_file("scenes/blinds-room.toml", width=160, height=120)
r = pm.render(scene, method="pm")
c = r.stats["icache"]

print(f"records: {c['records_pass_a']} in pass A, {c['records_pass_b']} in pass B")
print(f"lookups: {c['lookups']}, {c['mean_records_per_lookup']:.2f} records each")
print(f"radii shrunk by the gradient: {c['shrunk_by_gradient']}, by neighbour clamping: "
      f"{c['shrunk_by_clamping']}")
print(f"memory: {c['memory_bytes'] / 1024:.0f} KiB")

radii = c["radius_px"]
edges, counts = radii["edges"], radii["counts"]
fig, ax = plt.subplots(figsize=(5, 3.5))
ax.bar(edges[:-1], counts, width=[b - a for a, b in zip(edges, edges[1:])], align="edge")
ax.set_xlabel("record radius (pixels)")
ax.set_ylabel("records")
fig.tight_layout()
fig.savefig(out / "cache-radii.png", dpi=120)
r.write(out / "blinds-room.exr", png=out / "blinds-room.png", cache_image=out / "blinds-room-cache.png")
print(f"wrote {out / 'cache-radii.png'} and {out / 'blinds-room-cache.png'}")
