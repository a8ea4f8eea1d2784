"""pmrender's `glossy` material as a Mitsuba 3 Python BSDF plugin named "pm_phong".

Mitsuba 3 ships no Phong plugin, so this is the energy-conserving modified Phong of pmrender
(src/material.rs), two-sided:
    f(wi, wo) = Kd/pi + Ks (n+2)/(2 pi) cos^n(alpha),  alpha = angle between wo and the mirror of wi
(wi = toward the viewer, wo = toward the light, both on the same side of the shading normal).
Sampling: the diffuse lobe with probability max(Kd) / (max(Kd) + max(Ks)), else the cos^n lobe
around the mirror direction — the estimator is unbiased whatever the sampling, so only f matters.

Parameters (XML): <string name="albedo" value="r g b"/>, <string name="specular" value="r g b"/>,
<float name="exponent" value="n"/>, and optionally a texture (a nested <texture name="texture">, e.g. a
bitmap) with <float name="texture_scale" value="s"/>: the diffuse colour is then the texel times s (the
factor that brought Kd + Ks down to 1), at most 1 - Ks per channel, as pmrender's Scene::albedo for a
textured glossy material. Call register() after mi.set_variant and before loading a scene.
Works in every variant; fast only in JIT (llvm_*) variants.
"""
import drjit as dr
import mitsuba as mi


def _rgb(props, name):
    vals = [float(x) for x in str(props.get(name, "0 0 0")).split()]
    return mi.Color3f(*(vals * 3 if len(vals) == 1 else vals[:3]))


class PmPhong(mi.BSDF):
    def __init__(self, props):
        mi.BSDF.__init__(self, props)
        self.kd = _rgb(props, "albedo")
        self.ks = _rgb(props, "specular")
        self.n = float(props.get("exponent", 1.0))
        self.tex = props.get("texture", None)
        self.tex_scale = float(props.get("texture_scale", 1.0))
        d, s = dr.max(self.kd), dr.max(self.ks)
        d, s = float(d[0] if hasattr(d, "__len__") else d), float(s[0] if hasattr(s, "__len__") else s)
        self.p_diffuse = 1.0 if d + s <= 0.0 else d / (d + s)
        both = mi.BSDFFlags.FrontSide | mi.BSDFFlags.BackSide
        self.m_components = [mi.BSDFFlags.DiffuseReflection | both, mi.BSDFFlags.GlossyReflection | both]
        self.m_flags = self.m_components[0] | self.m_components[1]

    def _local(self, si, wo):
        """Mirror both directions into the hemisphere of si.wi (two-sided); returns (sign, wi, wo)."""
        s = dr.select(mi.Frame3f.cos_theta(si.wi) < 0, -1.0, 1.0)
        wi = mi.Vector3f(si.wi.x, si.wi.y, si.wi.z * s)
        wo = mi.Vector3f(wo.x, wo.y, wo.z * s)
        return s, wi, wo

    def _kd(self, si, active):
        """The diffuse colour at si: constant, or the scaled texel capped so that kd + ks <= 1."""
        if self.tex is None:
            return self.kd
        return dr.minimum(self.tex.eval(si, active) * self.tex_scale, 1.0 - self.ks)

    def _eval_pdf_local(self, kd, wi, wo, active):
        cos_o = mi.Frame3f.cos_theta(wo)
        valid = active & (mi.Frame3f.cos_theta(wi) > 0) & (cos_o > 0)
        r = mi.Vector3f(-wi.x, -wi.y, wi.z)
        cos_a = dr.clip(dr.dot(r, wo), 0.0, 1.0)
        lobe = dr.power(cos_a, self.n)
        f = kd * dr.inv_pi + self.ks * ((self.n + 2.0) * 0.5 * dr.inv_pi) * lobe
        pdf = self.p_diffuse * cos_o * dr.inv_pi + (1.0 - self.p_diffuse) * (self.n + 1.0) * 0.5 * dr.inv_pi * lobe
        return dr.select(valid, f * cos_o, 0.0), dr.select(valid, pdf, 0.0)

    def eval_pdf(self, ctx, si, wo, active=True):
        _, wi, wo = self._local(si, wo)
        return self._eval_pdf_local(self._kd(si, active), wi, wo, active)

    def eval(self, ctx, si, wo, active=True):
        return self.eval_pdf(ctx, si, wo, active)[0]

    def pdf(self, ctx, si, wo, active=True):
        return self.eval_pdf(ctx, si, wo, active)[1]

    def sample(self, ctx, si, sample1, sample2, active=True):
        s, wi, _ = self._local(si, si.wi)
        diffuse = sample1 < self.p_diffuse
        wo_d = mi.warp.square_to_cosine_hemisphere(sample2)
        cos_a = dr.power(sample2.x, 1.0 / (self.n + 1.0))
        sin_a = dr.safe_sqrt(1.0 - cos_a * cos_a)
        phi = dr.two_pi * sample2.y
        local = mi.Vector3f(sin_a * dr.cos(phi), sin_a * dr.sin(phi), cos_a)
        wo_g = mi.Frame3f(mi.Vector3f(-wi.x, -wi.y, wi.z)).to_world(local)
        wo = dr.select(diffuse, wo_d, wo_g)
        val, pdf = self._eval_pdf_local(self._kd(si, active), wi, wo, active)
        bs = mi.BSDFSample3f()
        bs.wo = mi.Vector3f(wo.x, wo.y, wo.z * s)
        bs.pdf = pdf
        bs.eta = 1.0
        bs.sampled_type = dr.select(diffuse, mi.UInt32(+mi.BSDFFlags.DiffuseReflection),
                                    mi.UInt32(+mi.BSDFFlags.GlossyReflection))
        bs.sampled_component = dr.select(diffuse, mi.UInt32(0), mi.UInt32(1))
        ok = active & (pdf > 0)
        return bs, dr.select(ok, val / dr.select(ok, pdf, 1.0), 0.0)

    def traverse(self, callback):
        pass

    def parameters_changed(self, keys):
        pass

    def to_string(self):
        tex = "" if self.tex is None else f", texture={self.tex} x {self.tex_scale}"
        return f"PmPhong[kd={self.kd}, ks={self.ks}, n={self.n}{tex}]"


def register():
    mi.register_bsdf("pm_phong", lambda props: PmPhong(props))
