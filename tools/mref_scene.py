"""Reads a pmrender scene (TOML + OBJ/MTL) into plain Python data, with pmrender's semantics.

Used by tools/mitsuba_reference.py; not a command. Nothing here depends on Mitsuba.

Semantics reproduced (src/scene/*.rs, the scene-format spec):
  * mesh transform: scale, then rotate about X, then Y, then Z (degrees), then translate;
    normals by the inverse transpose.
  * OBJ polygons are fan-triangulated (0, i, i+1); zero-area triangles are dropped.
  * MTL: Ke > 0 emits (area light); illum 3/5 mirror (Ks); illum 4/6/7 glass (Ni, 1.5 when absent
    or <= 1; Tf, 1 when absent); Ks > 0 and Ns > 1 glossy (scaled down so max(Kd + Ks) <= 1; map_Kd
    texture, its texels scaled by the same factor and capped at 1 - Ks); otherwise diffuse (Kd, 0.8
    when absent; map_Kd texture). Faces with no known material get the default diffuse 0.8.
  * [materials.NAME] overrides apply to every material of that name in every mesh.
"""
import math
import os
from dataclasses import dataclass, field


class SceneError(Exception):
    pass


@dataclass
class Material:
    name: str
    kind: str = "diffuse"  # diffuse | mirror | glass | glossy | null
    albedo: tuple = (0.8, 0.8, 0.8)
    texture: str | None = None  # absolute path
    texture_scale: float = 1.0  # glossy: the factor applied to Kd (and to the texels) so that Kd + Ks <= 1
    reflectance: tuple = (1.0, 1.0, 1.0)
    ior: float = 1.5
    transmittance: tuple = (1.0, 1.0, 1.0)
    specular: tuple = (0.0, 0.0, 0.0)
    exponent: float = 1.0
    emission: tuple = (0.0, 0.0, 0.0)

    def emissive(self):
        return max(self.emission) > 0.0


@dataclass
class Triangle:
    p: list  # three world-space points
    n: list | None  # three world-space unit normals, or None (flat)
    uv: list | None  # three (u, v), or None
    material: int
    boundary: int | None = None  # index into Scene.boundaries for a medium's boundary mesh
    outside: str | None = None  # a boundary triangle's medium on its outer side (None: vacuum)


@dataclass
class Scene:
    path: str
    camera: dict
    materials: list = field(default_factory=list)
    triangles: list = field(default_factory=list)
    lights: list = field(default_factory=list)
    max_depth: int = 64
    spp: int | None = None
    seed: int = 0
    notes: list = field(default_factory=list)
    media: dict = field(default_factory=dict)  # name -> {sigma_a, sigma_s, g}
    boundaries: list = field(default_factory=list)  # per boundary mesh: medium, outside, outward, volume
    camera_medium: str | None = None


# ---------------------------------------------------------------- small vector helpers
def sub(a, b):
    return (a[0] - b[0], a[1] - b[1], a[2] - b[2])


def cross(a, b):
    return (a[1] * b[2] - a[2] * b[1], a[2] * b[0] - a[0] * b[2], a[0] * b[1] - a[1] * b[0])


def dot(a, b):
    return a[0] * b[0] + a[1] * b[1] + a[2] * b[2]


def norm(a):
    return math.sqrt(dot(a, a))


def normalize(a):
    n = norm(a)
    return (a[0] / n, a[1] / n, a[2] / n) if n > 0 else (0.0, 0.0, 0.0)


def matmul(a, b):
    return [[sum(a[i][k] * b[k][j] for k in range(3)) for j in range(3)] for i in range(3)]


def apply(m, v):
    return tuple(m[i][0] * v[0] + m[i][1] * v[1] + m[i][2] * v[2] for i in range(3))


def rot(axis, deg):
    c, s = math.cos(math.radians(deg)), math.sin(math.radians(deg))
    if axis == 0:
        return [[1, 0, 0], [0, c, -s], [0, s, c]]
    if axis == 1:
        return [[c, 0, s], [0, 1, 0], [-s, 0, c]]
    return [[c, -s, 0], [s, c, 0], [0, 0, 1]]


def inverse_transpose(m):
    """Cofactor matrix / det = (m^-1)^T."""
    cof = [[0.0] * 3 for _ in range(3)]
    for i in range(3):
        for j in range(3):
            a = [[m[r][c] for c in range(3) if c != j] for r in range(3) if r != i]
            cof[i][j] = (-1) ** (i + j) * (a[0][0] * a[1][1] - a[0][1] * a[1][0])
    det = sum(m[0][j] * cof[0][j] for j in range(3))
    return [[cof[i][j] / det for j in range(3)] for i in range(3)]


def vec3(x, what):
    if isinstance(x, (int, float)):
        return (float(x),) * 3
    if not (isinstance(x, list) and len(x) == 3 and all(isinstance(v, (int, float)) for v in x)):
        raise SceneError(f"{what}: expected three numbers, got {x!r}")
    return tuple(float(v) for v in x)


# ---------------------------------------------------------------- MTL
def parse_mtl(path):
    """Returns {name: {key: [tokens]}} with the raw tokens of each statement (comments stripped)."""
    mats, cur = {}, None
    with open(path, encoding="utf-8", errors="replace") as f:
        for raw in f:
            line = raw.split("#", 1)[0].strip()
            if not line:
                continue
            key, _, rest = line.partition(" ")
            rest = rest.strip()
            if key == "newmtl":
                cur = mats.setdefault(rest, {})
            elif cur is not None:
                cur[key] = rest
    return mats


def floats(s, n=3):
    v = [float(t) for t in s.split()[:n]]
    if len(v) == 1:
        return (v[0],) * 3
    if len(v) >= 3:
        return tuple(v[:3])
    return None


def material_from_mtl(name, d, mtl_dir):
    kd = floats(d["Kd"]) if "Kd" in d else (0.8, 0.8, 0.8)
    ks = floats(d["Ks"]) if "Ks" in d else (0.0, 0.0, 0.0)
    ke = floats(d["Ke"]) if "Ke" in d else (0.0, 0.0, 0.0)
    ke = tuple(max(0.0, x) for x in (ke or (0, 0, 0)))
    ns = float(d["Ns"].split()[0]) if "Ns" in d else 0.0
    illum = int(float(d["illum"].split()[0])) if "illum" in d else None
    m = Material(name=name, emission=ke)
    if illum in (3, 5):
        m.kind, m.reflectance = "mirror", ks
    elif illum in (4, 6, 7):
        ni = float(d["Ni"].split()[0]) if "Ni" in d else 1.5
        m.kind, m.ior = "glass", (1.5 if ni <= 1.0 else ni)
        m.transmittance = floats(d["Tf"]) if "Tf" in d else (1.0, 1.0, 1.0)
    else:
        if max(ks) > 0.0 and ns > 1.0:
            set_glossy(m, kd, ks, ns)
        else:
            m.kind, m.albedo = "diffuse", kd
        tex = d.get("map_Kd", "").strip()
        if tex:
            m.texture = resolve_texture(mtl_dir, tex)
    return m


def set_glossy(m, kd, ks, exponent):
    """Modified Phong, scaled so that max over channels of kd + ks <= 1 (as pmrender)."""
    total = max(a + b for a, b in zip(kd, ks))
    s = 1.0 / total if total > 1.0 else 1.0
    m.kind, m.albedo, m.specular, m.exponent = "glossy", tuple(x * s for x in kd), tuple(x * s for x in ks), exponent
    m.texture_scale = s


def resolve_texture(directory, name):
    """The file, or a case-insensitive match of its file name in the same folder (as pmrender)."""
    p = os.path.join(directory, name.replace("\\", "/"))
    if os.path.isfile(p):
        return os.path.abspath(p)
    parent, want = os.path.dirname(p), os.path.basename(p).lower()
    if os.path.isdir(parent):
        for f in os.listdir(parent):
            if f.lower() == want:
                return os.path.abspath(os.path.join(parent, f))
    raise SceneError(f"texture '{name}' not found in '{directory}'")
