"""Photon-count convergence of pm on the caustic Cornell box, against Mitsuba 3's path-traced reference:
relMSE of the image and of its caustic and indirect terms, as a table and a log-log chart.

    python docs/python/convergence.py [OUT_DIR]        (from the repository's root)
"""

import sys
from pathlib import Path

import matplotlib

matplotlib.use("Agg")
import matplotlib.pyplot as plt

import pmrender as pm

out = Path(sys.argv[1] if len(sys.argv) > 1 else "out/python")
out.mkdir(parents=True, exist_ok=True)

scene = pm.load_file("scenes/cornell-caustics.toml")
reference = "tests/reference/cornell-caustics-path.exr"   # 160×128: the renders take its size
counts = [1e4, 3e4, 1e5, 3e5]
rows = pm.converge(scene, photons=counts, reference=reference, method="pm")

print(f"{'photons':>9} {'time s':>7} {'beauty':>10} {'caustic':>10} {'indirect':>10}")
for r in rows:
    print(f"{r['photons']:>9} {r['time_s']:>7.2f} {r['beauty']:>10.2e} {r['caustic']:>10.2e} "
          f"{r['indirect']:>10.2e}")

fig, ax = plt.subplots(figsize=(5, 3.5))
for key in ("beauty", "caustic", "indirect"):
    ax.loglog([r["photons"] for r in rows], [r[key] for r in rows], "o-", label=key)
ax.set_xlabel("photons per map")
ax.set_ylabel("relMSE against the reference")
ax.legend()
fig.tight_layout()
fig.savefig(out / "convergence.png", dpi=120)
# The reference has no caustic and indirect layers: those terms are measured against the largest
# count's render, whose own row is NaN.
print(f"wrote {out / 'convergence.png'}")
