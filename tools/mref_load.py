"""Loads a pmrender scene file (TOML) with its OBJ meshes into mref_scene.Scene (world-space triangles).

Used by tools/mitsuba_reference.py; not a command. See mref_scene.py for the semantics reproduced.
"""
import math
import os
import tomllib

from mref_scene import (Material, Scene, SceneError, Triangle, apply, cross, inverse_transpose,
                        material_from_mtl, matmul, norm, normalize, parse_mtl, resolve_texture, rot,
                        set_glossy, sub, vec3, dot)

OVERRIDE_KEYS = {
    "diffuse": {"albedo", "texture"},
    "mirror": {"reflectance"},
    "glass": {"ior", "transmittance"},
    "glossy": {"albedo", "specular", "exponent", "texture"},
    "null": set(),
}


def transform(mesh):
    s = mesh.get("scale", 1.0)
    s = vec3(s, "mesh.scale")
    r = vec3(mesh.get("rotate", [0.0, 0.0, 0.0]), "mesh.rotate")
    t = vec3(mesh.get("translate", [0.0, 0.0, 0.0]), "mesh.translate")
    if s[0] * s[1] * s[2] == 0.0:
        raise SceneError("mesh.scale must be non-zero")
    rmat = matmul(rot(2, r[2]), matmul(rot(1, r[1]), rot(0, r[0])))
    m = [[rmat[i][j] * s[j] for j in range(3)] for i in range(3)]
    return m, t, inverse_transpose(m)


def read_obj(path):
    """Yields (material_name or None, [(v, vt, vn) index triples]) per polygon, and the arrays."""
    vs, vts, vns, faces, mtllibs, cur = [], [], [], [], [], None
    with open(path, encoding="utf-8", errors="replace") as f:
        for raw in f:
            tok = raw.split("#", 1)[0].split()
            if not tok:
                continue
            tag = tok[0]
            if tag == "v":
                vs.append(tuple(float(x) for x in tok[1:4]))
            elif tag == "vt":
                vts.append((float(tok[1]), float(tok[2]) if len(tok) > 2 else 0.0))
            elif tag == "vn":
                vns.append(tuple(float(x) for x in tok[1:4]))
            elif tag == "usemtl":
                cur = raw.split("#", 1)[0].strip()[6:].strip()
            elif tag == "mtllib":
                mtllibs.append(raw.split("#", 1)[0].strip()[6:].strip())
            elif tag == "f":
                corners = []
                for c in tok[1:]:
                    parts = c.split("/")
                    idx = []
                    for slot, arr in enumerate((vs, vts, vns)):
                        p = parts[slot] if slot < len(parts) else ""
                        if not p:
                            idx.append(None)
                            continue
                        k = int(p)
                        idx.append(k - 1 if k > 0 else len(arr) + k)
                    corners.append(tuple(idx))
                if len(corners) >= 3:
                    faces.append((cur, corners))
    return vs, vts, vns, faces, mtllibs


def load_mesh(scene, mesh, toml_dir, by_name, boundary=None):
    obj_path = os.path.join(toml_dir, mesh["obj"])
    if not os.path.isfile(obj_path):
        raise SceneError(f"mesh.obj: file '{obj_path}' not found")
    m, t, nm = transform(mesh)
    vs, vts, vns, faces, mtllibs = read_obj(obj_path)
    obj_dir = os.path.dirname(obj_path)
    local = {}
    for lib in mtllibs:
        lib_path = os.path.join(obj_dir, lib)
        for name, d in parse_mtl(lib_path).items():
            mat = material_from_mtl(name, d, os.path.dirname(lib_path))
            local[name] = len(scene.materials)
            by_name.setdefault(name, []).append(len(scene.materials))
            scene.materials.append(mat)
    xp = lambda p: tuple(a + b for a, b in zip(apply(m, p), t))
    for mat_name, corners in faces:
        if mat_name is not None and mat_name not in local:
            # As pmrender: a `usemtl` name no library defines is the default diffuse 0.8 under that name,
            # so that a [materials.NAME] override can reach it.
            local[mat_name] = len(scene.materials)
            by_name.setdefault(mat_name, []).append(len(scene.materials))
            scene.materials.append(Material(name=mat_name))
        if mat_name in local:
            mi = local[mat_name]
        else:
            mi = default_material(scene)
        has_n = all(c[2] is not None for c in corners)
        has_uv = all(c[1] is not None for c in corners)
        for k in range(1, len(corners) - 1):
            tri = (corners[0], corners[k], corners[k + 1])
            p = [xp(vs[c[0]]) for c in tri]
            if not norm(cross(sub(p[1], p[0]), sub(p[2], p[0]))) > 0.0:
                continue  # degenerate: pmrender drops it too
            n = [normalize(apply(nm, vns[c[2]])) for c in tri] if has_n else None
            uv = [vts[c[1]] for c in tri] if has_uv else None
            scene.triangles.append(Triangle(p=p, n=n, uv=uv, material=mi, boundary=boundary))


def default_material(scene):
    for i, mat in enumerate(scene.materials):
        if getattr(mat, "is_default", False):
            return i
    mat = Material(name="default")
    mat.is_default = True
    scene.materials.append(mat)
    return len(scene.materials) - 1


def apply_override(mat, d, toml_dir):
    """`[materials.NAME]` as pmrender's mtl::apply_override: keys not given default from the current
    material when it is diffuse or glossy (albedo, specular, exponent), else albedo 0.8, specular 0,
    exponent 1; a diffuse or glossy material keeps its texture when its type is unchanged, else only
    a `texture` given; mirror reflectance defaults to the current mirror's, else that specular if > 0, else 1;
    glass to the current glass's ior and transmittance, else 1.5 and 1. The type defaults to the
    current one."""
    kind = d.get("type", mat.kind)
    if kind not in OVERRIDE_KEYS:
        raise SceneError(f"materials.{mat.name}: unknown type '{kind}'")
    extra = set(d) - OVERRIDE_KEYS[kind] - {"type", "emission"}
    if extra:
        raise SceneError(f"materials.{mat.name}: keys {sorted(extra)} do not apply to type '{kind}'")
    if mat.kind == "diffuse":
        kd, ks, ns = mat.albedo, (0.0, 0.0, 0.0), 1.0
    elif mat.kind == "glossy":
        kd, ks, ns = mat.albedo, mat.specular, mat.exponent
    else:
        kd, ks, ns = (0.8, 0.8, 0.8), (0.0, 0.0, 0.0), 1.0
    get = lambda k, dflt: vec3(d[k], f"materials.{mat.name}.{k}") if k in d else dflt
    was = mat.kind
    if kind != mat.kind or kind not in ("diffuse", "glossy"):
        mat.texture = None
    if kind in ("diffuse", "glossy") and "texture" in d:
        mat.texture = resolve_texture(toml_dir, d["texture"])
    if kind == "diffuse":
        mat.albedo = get("albedo", kd)
    elif kind == "mirror":
        own = mat.reflectance if was == "mirror" else None
        mat.reflectance = get("reflectance", own or (ks if max(ks) > 0 else (1.0, 1.0, 1.0)))
    elif kind == "glass":
        ior = float(d.get("ior", mat.ior if was == "glass" else 1.5))
        if not ior > 1.0:
            raise SceneError(f"materials.{mat.name}.ior = {ior} must be > 1")
        own_t = mat.transmittance if was == "glass" else (1.0, 1.0, 1.0)
        mat.ior, mat.transmittance = ior, get("transmittance", own_t)
    elif kind == "glossy":
        # A texel stands for Kd: when Kd is the old glossy one, it was scaled down once already.
        old_scale = mat.texture_scale if was == "glossy" and "albedo" not in d else 1.0
        set_glossy(mat, get("albedo", kd), get("specular", ks), float(d.get("exponent", max(ns, 1.0))))
        mat.texture_scale *= old_scale
    mat.kind = kind
    if "emission" in d:
        mat.emission = vec3(d["emission"], f"materials.{mat.name}.emission")


def load_light(d):
    kind = d.get("type")
    if kind == "point":
        return {"type": "point", "position": vec3(d["position"], "light.position"),
                "intensity": vec3(d["intensity"], "light.intensity")}
    if kind == "spot":
        cone = float(d.get("cone_angle", 30.0))
        falloff = float(d.get("falloff_start", cone * 0.75))
        if not (0.0 < cone <= 180.0 and 0.0 <= falloff <= cone):
            raise SceneError(f"spot light: cone_angle {cone} / falloff_start {falloff} out of range")
        return {"type": "spot", "position": vec3(d["position"], "light.position"),
                "target": vec3(d["target"], "light.target"), "intensity": vec3(d["intensity"], "light.intensity"),
                "cone_angle": cone, "falloff_start": falloff}
    if kind == "directional":
        return {"type": "directional", "direction": normalize(vec3(d["direction"], "light.direction")),
                "irradiance": vec3(d["irradiance"], "light.irradiance")}
    raise SceneError(f"unknown light type {kind!r}")


def contains(tris, q):
    """Parity of a ray's crossings with the triangles `tris` (a closed mesh): inside when odd."""
    d = normalize((0.5711, 0.6353, 0.5198))
    n = 0
    for p in tris:
        e1, e2 = sub(p[1], p[0]), sub(p[2], p[0])
        h = cross(d, e2)
        det = dot(e1, h)
        if abs(det) < 1e-300:
            continue
        s_ = sub(q, p[0])
        u = dot(s_, h) / det
        r = cross(s_, e1)
        v = dot(d, r) / det
        t = dot(e2, r) / det
        if u >= 0 and v >= 0 and u + v <= 1 and t > 0:
            n += 1
    return n % 2 == 1


def media_sides(scene):
    """As pmrender: a boundary mesh's inside by the sign of its volume, its outside the medium of the
    smallest other boundary mesh containing it, the camera's medium the innermost around the eye."""
    tris = [[t.p for t in scene.triangles if t.boundary == b] for b in range(len(scene.boundaries))]
    for b, ts in zip(scene.boundaries, tris):
        vol = sum(dot(p[0], cross(p[1], p[2])) for p in ts) / 6.0
        b["volume"], b["outward"] = abs(vol), vol > 0
    def innermost(q, skip=None):
        best = None
        for i, (b, ts) in enumerate(zip(scene.boundaries, tris)):
            if i != skip and contains(ts, q) and (best is None or b["volume"] < scene.boundaries[best]["volume"]):
                best = i
        return None if best is None else scene.boundaries[best]["medium"]
    for i, (b, ts) in enumerate(zip(scene.boundaries, tris)):
        big = max(ts, key=lambda p: norm(cross(sub(p[1], p[0]), sub(p[2], p[0]))))
        c = tuple(sum(x) / 3 for x in zip(*big))
        ng = normalize(cross(sub(big[1], big[0]), sub(big[2], big[0])))
        area = norm(cross(sub(big[1], big[0]), sub(big[2], big[0]))) / 2
        inward = tuple(-x for x in ng) if b["outward"] else ng
        b["outside"] = innermost(tuple(ci + 1e-3 * math.sqrt(area) * w for ci, w in zip(c, inward)), skip=i)
    for t in scene.triangles:
        if t.boundary is not None:
            t.outside = scene.boundaries[t.boundary]["outside"]
    shared_faces(scene)
    scene.camera_medium = innermost(scene.camera["eye"])


def shared_faces(scene):
    """As pmrender, face by face where two media meet: a boundary triangle lying on another boundary
    mesh's face, the two facing away from each other, has that mesh's medium outside."""
    import numpy as np
    by_boundary = {}
    for t in scene.triangles:
        if t.boundary is not None:
            by_boundary.setdefault(t.boundary, []).append(t)
    if len(by_boundary) < 2:
        return
    geo = {}
    for b, ts in by_boundary.items():
        p = np.array([t.p for t in ts], dtype=float)
        n = np.cross(p[:, 1] - p[:, 0], p[:, 2] - p[:, 0])
        n /= np.linalg.norm(n, axis=1, keepdims=True)
        if not scene.boundaries[b]["outward"]:
            n = -n
        geo[b] = (p, n)
    for a, ts in by_boundary.items():
        pa, na = geo[a]
        c = pa.mean(axis=1)
        eps = 1e-5 * max(1.0, float(np.abs(c).max()))
        for b, (pb, nb) in geo.items():
            if b == a:
                continue
            # Distance of each centroid of a to each plane of b, and barycentrics in b's triangles.
            e1, e2 = pb[:, 1] - pb[:, 0], pb[:, 2] - pb[:, 0]
            w = c[:, None, :] - pb[None, :, 0]
            dist = np.abs(np.einsum("ijk,jk->ij", w, nb))
            d11, d12, d22 = (e1 * e1).sum(1), (e1 * e2).sum(1), (e2 * e2).sum(1)
            w1, w2 = np.einsum("ijk,jk->ij", w, e1), np.einsum("ijk,jk->ij", w, e2)
            det = d11 * d22 - d12 * d12
            u = (d22 * w1 - d12 * w2) / det
            v = (d11 * w2 - d12 * w1) / det
            facing = (na @ nb.T) < -0.99
            on = (dist < eps) & (u >= -1e-6) & (v >= -1e-6) & (u + v <= 1 + 1e-6) & facing
            for i in np.nonzero(on.any(axis=1))[0]:
                ts[i].outside = scene.boundaries[b]["medium"]


def load(path):
    with open(path, "rb") as f:
        doc = tomllib.load(f)
    if doc.get("version", 1) != 1:
        raise SceneError(f"unsupported version {doc['version']}")
    toml_dir = os.path.dirname(os.path.abspath(path))
    cam = doc["camera"]
    camera = {"eye": vec3(cam["eye"], "camera.eye"), "target": vec3(cam["target"], "camera.target"),
              "up": vec3(cam.get("up", [0.0, 1.0, 0.0]), "camera.up"), "fov": float(cam["fov"]),
              "width": int(cam["width"]), "height": int(cam["height"])}
    r = doc.get("render", {})
    scene = Scene(path=os.path.abspath(path), camera=camera, max_depth=int(r.get("max_depth", 64)),
                  spp=r.get("spp"), seed=int(r.get("seed", 0)))
    by_name = {}
    scene.media = {m["name"]: {"sigma_a": vec3(m["sigma_a"], "medium.sigma_a"), "sigma_s": vec3(m["sigma_s"], "medium.sigma_s"),
                               "g": float(m.get("g", 0.0))} for m in doc.get("medium", [])}
    for mesh in doc.get("mesh", []):
        boundary = None
        if "interior" in mesh:
            if mesh["interior"] not in scene.media:
                raise SceneError(f"mesh.interior: no [[medium]] is named '{mesh['interior']}'")
            boundary = len(scene.boundaries)
            scene.boundaries.append({"medium": mesh["interior"]})
        load_mesh(scene, mesh, toml_dir, by_name, boundary)
    if not scene.triangles:
        raise SceneError("the scene has no triangles")
    for name, d in doc.get("materials", {}).items():
        if name not in by_name:
            raise SceneError(f"materials.{name}: no mesh uses a material named '{name}'")
        for i in by_name[name]:
            apply_override(scene.materials[i], d, toml_dir)
    scene.lights = [load_light(d) for d in doc.get("light", [])]
    if scene.boundaries:
        media_sides(scene)
    if not scene.lights and not any(scene.materials[t.material].emissive() for t in scene.triangles):
        raise SceneError("the scene has no lights (add a [[light]] or a material with Ke > 0)")
    return scene
