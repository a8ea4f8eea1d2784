"""Writes a loaded pmrender scene (mref_scene.Scene) as a Mitsuba 3 XML scene plus one OBJ per
(material, shading) group, with every mesh transform already applied to the vertices.

Used by tools/mitsuba_reference.py; not a command.

Choices that make Mitsuba agree with pmrender:
  * Emissive triangles are written flat (no vn, face_normals=true) and wound so that their geometric
    normal is pmrender's emission normal (the face normal, flipped when the vertex normals summed point
    the other way). Mitsuba's `area` emitter is one-sided along that normal.
  * Triangles without vertex normals go to a face_normals=true shape (Mitsuba would otherwise smooth
    them); triangles with normals keep them as shading normals.
  * Non-dielectric BSDFs are wrapped in `twosided` (pm_phong is two-sided by itself).
  * pmrender's max_depth N runs N bounces with next-event estimation at each, i.e. paths of up to N+1
    segments: Mitsuba's path integrator gets max_depth = N + 1 (Mitsuba counts segments).
"""
import math
import os
from xml.sax.saxutils import quoteattr

from mref_scene import cross, dot, normalize, sub


def fmt3(v):
    return ", ".join("%.9g" % x for x in v)


def group_triangles(scene):
    """{(material, flat, boundary, outside medium): [(p, n, uv)]} with emissive triangles flattened and re-wound, and a
    medium's boundary triangles wound so that their normal points out of the medium (Mitsuba's
    interior is behind the normal)."""
    groups = {}
    for t in scene.triangles:
        if t.boundary is not None:
            p = list(t.p) if scene.boundaries[t.boundary]["outward"] else [t.p[0], t.p[2], t.p[1]]
            n = t.n if scene.boundaries[t.boundary]["outward"] or t.n is None else [t.n[0], t.n[2], t.n[1]]
            uv = t.uv if scene.boundaries[t.boundary]["outward"] or not t.uv else [t.uv[0], t.uv[2], t.uv[1]]
            groups.setdefault((t.material, n is None, t.boundary, t.outside or ""), []).append((p, n, uv))
            continue
        mat = scene.materials[t.material]
        p, n = list(t.p), t.n
        if mat.emissive():
            ng = cross(sub(p[1], p[0]), sub(p[2], p[0]))
            if n is not None and dot(tuple(sum(c) for c in zip(*n)), ng) < 0.0:
                p = [p[0], p[2], p[1]]
                t_uv = [t.uv[0], t.uv[2], t.uv[1]] if t.uv else None
            else:
                t_uv = t.uv
            groups.setdefault((t.material, True, -1, ""), []).append((p, None, t_uv))
        else:
            groups.setdefault((t.material, n is None, -1, ""), []).append((p, n, t.uv))
    return groups


def write_obj(path, tris, with_uv):
    lines = []
    for k, (p, n, uv) in enumerate(tris):
        for j in range(3):
            lines.append("v %.9g %.9g %.9g" % p[j])
            if with_uv:
                lines.append("vt %.9g %.9g" % (uv[j] if uv else (0.0, 0.0)))
            if n is not None:
                lines.append("vn %.9g %.9g %.9g" % n[j])
        i = 3 * k
        if n is not None and with_uv:
            corners = [f"{i+j+1}/{i+j+1}/{i+j+1}" for j in range(3)]
        elif n is not None:
            corners = [f"{i+j+1}//{i+j+1}" for j in range(3)]
        elif with_uv:
            corners = [f"{i+j+1}/{i+j+1}" for j in range(3)]
        else:
            corners = [str(i + j + 1) for j in range(3)]
        lines.append("f " + " ".join(corners))
    with open(path, "w") as f:
        f.write("\n".join(lines) + "\n")


def bsdf_xml(mat):
    if mat.kind == "null":
        return '<bsdf type="null"/>'
    if mat.kind == "glass":
        return (f'<bsdf type="dielectric"><float name="int_ior" value="{mat.ior:.9g}"/>'
                f'<float name="ext_ior" value="1"/>'
                f'<rgb name="specular_transmittance" value="{fmt3(mat.transmittance)}"/></bsdf>')
    if mat.kind == "glossy":
        # A texture is the diffuse colour: texel x texture_scale, capped at 1 - Ks (tools/mref_phong.py).
        tex = (f'<texture type="bitmap" name="texture"><string name="filename" value={quoteattr(mat.texture)}/>'
               f'<string name="filter_type" value="bilinear"/><string name="wrap_mode" value="repeat"/></texture>'
               f'<float name="texture_scale" value="{mat.texture_scale:.9g}"/>' if mat.texture else "")
        return (f'<bsdf type="pm_phong"><string name="albedo" value="{" ".join("%.9g" % x for x in mat.albedo)}"/>'
                f'<string name="specular" value="{" ".join("%.9g" % x for x in mat.specular)}"/>'
                f'<float name="exponent" value="{mat.exponent:.9g}"/>{tex}</bsdf>')
    if mat.kind == "mirror":
        inner = (f'<bsdf type="conductor"><string name="material" value="none"/>'
                 f'<rgb name="specular_reflectance" value="{fmt3(mat.reflectance)}"/></bsdf>')
    elif mat.texture:
        inner = (f'<bsdf type="diffuse"><texture type="bitmap" name="reflectance">'
                 f'<string name="filename" value={quoteattr(mat.texture)}/>'
                 f'<string name="filter_type" value="bilinear"/><string name="wrap_mode" value="repeat"/>'
                 f'</texture></bsdf>')
    else:
        inner = f'<bsdf type="diffuse"><rgb name="reflectance" value="{fmt3(mat.albedo)}"/></bsdf>'
    return f'<bsdf type="twosided">{inner}</bsdf>'


def light_xml(light):
    if light["type"] == "point":
        x, y, z = light["position"]
        return (f'<emitter type="point"><point name="position" x="{x:.9g}" y="{y:.9g}" z="{z:.9g}"/>'
                f'<rgb name="intensity" value="{fmt3(light["intensity"])}"/></emitter>')
    if light["type"] == "spot":
        # pmrender: full intensity within falloff_start, zero beyond cone_angle, linear in the angle between:
        # exactly Mitsuba's spot falloff with cutoff_angle = cone_angle and beam_width = falloff_start
        # (beam_width kept a hair below cutoff_angle so Mitsuba's 1/(cutoff - beam) stays finite).
        cone, beam = light["cone_angle"], min(light["falloff_start"], light["cone_angle"] * (1 - 1e-5))
        d = normalize(sub(light["target"], light["position"]))
        up = (0.0, 1.0, 0.0) if abs(d[1]) < 0.9 else (1.0, 0.0, 0.0)
        return (f'<emitter type="spot"><transform name="to_world">{lookat(light["position"], light["target"], up)}'
                f'</transform><rgb name="intensity" value="{fmt3(light["intensity"])}"/>'
                f'<float name="cutoff_angle" value="{cone:.9g}"/><float name="beam_width" value="{beam:.9g}"/></emitter>')
    x, y, z = light["direction"]
    return (f'<emitter type="directional"><vector name="direction" x="{x:.9g}" y="{y:.9g}" z="{z:.9g}"/>'
            f'<rgb name="irradiance" value="{fmt3(light["irradiance"])}"/></emitter>')


def lookat(origin, target, up):
    return f'<lookat origin="{fmt3(origin)}" target="{fmt3(target)}" up="{fmt3(up)}"/>'


def clip_range(scene):
    lo = [min(p[k] for t in scene.triangles for p in t.p) for k in range(3)]
    hi = [max(p[k] for t in scene.triangles for p in t.p) for k in range(3)]
    extent = math.dist(lo, hi) or 1.0
    eye_far = max(math.dist(scene.camera["eye"], c) for c in (lo, hi))
    return 1e-5 * extent, 10.0 * (extent + eye_far)


def emitter_offset(scene):
    """How far behind a transparent emitter its surface is drawn: 20 times Mitsuba's ray offset
    ((1 + max |p|) * RayEpsilon, RayEpsilon = 1500 * 2^-24) at the scene's largest coordinate, enough
    for the offsets of a few null boundaries crossed on the way."""
    extent = max(abs(p[k]) for t in scene.triangles for p in t.p for k in range(3))
    return 20.0 * (1.0 + extent) * 1500.0 * 2.0 ** -24


def behind(tris, d):
    """Flat triangles moved by `d` against their geometric normal."""
    out = []
    for p, n, uv in tris:
        ng = normalize(cross(sub(p[1], p[0]), sub(p[2], p[0])))
        out.append(([tuple(c - d * w for c, w in zip(v, ng)) for v in p], None, uv))
    return out


def export(scene, out_dir, spp, width, height):
    """Writes scene.xml and its OBJs into out_dir; returns the XML path."""
    os.makedirs(out_dir, exist_ok=True)
    cam = scene.camera
    near, far = clip_range(scene)
    media = bool(scene.boundaries)
    mid = lambda name: "medium_" + "".join(c if c.isalnum() else "_" for c in name)
    body = [
        f'<integrator type="{"volpath" if media else "path"}"><integer name="max_depth" value="{scene.max_depth + 1}"/>'
        f'<boolean name="hide_emitters" value="false"/></integrator>',
        f'<sensor type="perspective"><string name="fov_axis" value="y"/><float name="fov" value="{cam["fov"]:.9g}"/>'
        f'<float name="near_clip" value="{near:.9g}"/><float name="far_clip" value="{far:.9g}"/>'
        f'<transform name="to_world">{lookat(cam["eye"], cam["target"], cam["up"])}</transform>'
        f'<sampler type="independent"><integer name="sample_count" value="{spp}"/></sampler>'
        f'<film type="hdrfilm"><integer name="width" value="{width}"/><integer name="height" value="{height}"/>'
        f'<string name="pixel_format" value="rgb"/><rfilter type="box"/></film>'
        + (f'<ref id="{mid(scene.camera_medium)}"/>' if scene.camera_medium else "") + '</sensor>',
    ]
    for name, m in scene.media.items():
        st = tuple(a + b for a, b in zip(m["sigma_a"], m["sigma_s"]))
        albedo = tuple(s_ / t if t > 0 else 0.0 for s_, t in zip(m["sigma_s"], st))
        # An RGB sigma_t is read as a reflectance (each channel at most 1): scaled into that range.
        scale = max(max(st), 1.0)
        body.insert(0, f'<medium type="homogeneous" id="{mid(name)}"><rgb name="albedo" value="{fmt3(albedo)}"/>'
                       f'<rgb name="sigma_t" value="{fmt3(tuple(x / scale for x in st))}"/>'
                       f'<float name="scale" value="{scale:.9g}"/><phase type="hg"><float name="g" value="{m["g"]:.9g}"/></phase></medium>')
    for (mi, flat, boundary, outside), tris in sorted(group_triangles(scene).items()):
        mat = scene.materials[mi]
        faces = "" if boundary < 0 or outside == (scene.boundaries[boundary]["outside"] or "") else "_" + mid(outside)
        name = f"m{mi:03d}_{'flat' if flat else 'smooth'}{'' if boundary < 0 else f'_b{boundary}{faces}'}.obj"
        interface = ""
        if boundary >= 0:
            b = scene.boundaries[boundary]
            interface = f'<ref name="interior" id="{mid(b["medium"])}"/>'
            if outside:
                interface += f'<ref name="exterior" id="{mid(outside)}"/>'
        elif media:
            # Every other surface in a medium keeps the ray's medium: in Mitsuba a shape without an
            # interface does too, except a dielectric's transmission, which pmrender's scenes avoid by
            # making their glass a boundary.
            pass
        write_obj(os.path.join(out_dir, name), tris, with_uv=bool(mat.texture))
        emitter = (f'<emitter type="area"><rgb name="radiance" value="{fmt3(mat.emission)}"/></emitter>'
                   if mat.emissive() else "")
        bsdf = bsdf_xml(mat)
        if emitter and media:
            # volpath moves a shadow ray's origin off every null boundary it crosses, along the boundary's
            # normal, after cutting the ray ShadowEpsilon short of the light: a grazing ray to an emitter
            # just beyond a boundary parallel to it then ends inside the emitter and is blocked by its own
            # surface. The emitter is made transparent (null) and its surface drawn again just behind it.
            twin = name.replace(".obj", "_surface.obj")
            write_obj(os.path.join(out_dir, twin), behind(tris, emitter_offset(scene)), with_uv=bool(mat.texture))
            body.append(f'<shape type="obj"><string name="filename" value="{twin}"/>'
                        f'<boolean name="face_normals" value="true"/>{bsdf}</shape>')
            bsdf = '<bsdf type="null"/>'
        body.append(f'<!-- material {mat.name.replace("--", "- -")} ({mat.kind}) -->\n<shape type="obj">'
                    f'<string name="filename" value="{name}"/>'
                    f'<boolean name="face_normals" value="{"true" if flat else "false"}"/>'
                    f'{bsdf}{emitter}{interface}</shape>')
    body += [light_xml(l) for l in scene.lights]
    xml = os.path.join(out_dir, "scene.xml")
    with open(xml, "w") as f:
        f.write('<scene version="3.0.0">\n' + "\n".join(body) + "\n</scene>\n")
    return xml
