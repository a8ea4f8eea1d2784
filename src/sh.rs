//! Real spherical harmonics in world space, and modified Phong's lobe as a zonal kernel: what the
//! glossy radiance cache and the glossy atlas texels store and how they turn it into outgoing radiance.
//!
//! What is stored is the incident radiance times the cosine to the surface normal, `g(ω) = L(ω)·cos θ`
//! (zero below the surface), projected on the bands `0 … order − 1` (`order²` coefficients per colour
//! channel). The glossy part of modified Phong, `ks·(n+2)/(2π)·cosⁿα` with α the angle to the mirror
//! direction `r` of the outgoing direction, is a kernel of `ω·r` alone, so by the Funk–Hecke theorem the
//! light it reflects is `Σ_l λ_l Σ_m g_lm Y_lm(r)` with `λ_l = 2π ∫ K(t) P_l(t) dt`: one dot product,
//! whatever the outgoing direction. Coefficients are kept in world space: no rotation into a lookup
//! frame is needed, at the price of the lower hemisphere's unused half of the basis.

use glam::Vec3;

/// Bands at most (100 coefficients per channel, as in Křivánek et al.'s radiance caching).
pub const MAX_ORDER: usize = 10;

/// Coefficients of `order` bands.
pub const fn len(order: usize) -> usize {
    order * order
}

/// The real spherical harmonics of bands `0 … order − 1` at unit direction `d`, written to `out`
/// (`len(order)` values, index `l² + l + m`). Orthonormal over the sphere.
pub fn eval(order: usize, d: Vec3, out: &mut [f32]) {
    debug_assert!(order <= MAX_ORDER && out.len() >= len(order));
    if order <= 4 {
        eval_low(order, d, out);
        return;
    }
    eval_recurrence(order, d, out);
}

/// [`eval`] for up to 4 bands in closed form, in f32: the glossy texels evaluate it at every read, where
/// the f64 recurrence is costly.
fn eval_low(order: usize, d: Vec3, out: &mut [f32]) {
    let (x, y, z) = (d.x, d.y, d.z);
    let mut all = [0.0f32; 16];
    all[0] = 0.282_094_8;
    all[1] = 0.488_602_5 * y;
    all[2] = 0.488_602_5 * z;
    all[3] = 0.488_602_5 * x;
    all[4] = 1.092_548_4 * x * y;
    all[5] = 1.092_548_4 * y * z;
    all[6] = 0.315_391_57 * (3.0 * z * z - 1.0);
    all[7] = 1.092_548_4 * x * z;
    all[8] = 0.546_274_2 * (x * x - y * y);
    all[9] = 0.590_043_6 * (3.0 * x * x * y - y * y * y);
    all[10] = 2.890_611_4 * x * y * z;
    all[11] = 0.457_045_8 * y * (5.0 * z * z - 1.0);
    all[12] = 0.373_176_33 * z * (5.0 * z * z - 3.0);
    all[13] = 0.457_045_8 * x * (5.0 * z * z - 1.0);
    all[14] = 1.445_305_7 * z * (x * x - y * y);
    all[15] = 0.590_043_6 * (x * x * x - 3.0 * x * y * y);
    let n = len(order);
    out[..n].copy_from_slice(&all[..n]);
}

/// [`eval`] by the associated Legendre recurrence, in f64.
fn eval_recurrence(order: usize, d: Vec3, out: &mut [f32]) {
    let z = d.z as f64;
    // (x + iy)^m = sinᵐθ·(cos mφ + i sin mφ), built up m by m.
    let (mut cm, mut sm) = (1.0f64, 0.0f64);
    // P̃_m^m = (2m − 1)!!: the associated Legendre function without its sinᵐθ factor.
    let mut pmm = 1.0f64;
    for m in 0..order {
        if m > 0 {
            let (c, s) = (
                cm * d.x as f64 - sm * d.y as f64,
                cm * d.y as f64 + sm * d.x as f64,
            );
            cm = c;
            sm = s;
            pmm *= (2 * m - 1) as f64;
        }
        let (mut p_prev, mut p) = (0.0f64, pmm);
        for l in m..order {
            if l == m + 1 {
                p_prev = p;
                p = z * (2 * m + 1) as f64 * pmm;
            } else if l > m + 1 {
                let next =
                    ((2 * l - 1) as f64 * z * p - (l + m - 1) as f64 * p_prev) / (l - m) as f64;
                p_prev = p;
                p = next;
            }
            let k = norm(l, m);
            let i = l * l + l;
            if m == 0 {
                out[i] = (k * p) as f32;
            } else {
                let k = std::f64::consts::SQRT_2 * k * p;
                out[i + m] = (k * cm) as f32;
                out[i - m] = (k * sm) as f32;
            }
        }
    }
}

/// `sqrt((2l+1)/(4π) · (l−m)!/(l+m)!)`.
fn norm(l: usize, m: usize) -> f64 {
    let ratio: f64 = ((l - m + 1)..=(l + m)).map(|i| 1.0 / i as f64).product();
    ((2 * l + 1) as f64 / (4.0 * std::f64::consts::PI) * ratio).sqrt()
}

/// Modified Phong's glossy lobe of exponent `n` as a zonal kernel: `λ_l` for bands `0 … MAX_ORDER − 1`,
/// per unit of specular reflectance.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct PhongKernel {
    pub lambda: [f32; MAX_ORDER],
}

impl PhongKernel {
    /// `λ_l = (n+2) ∫₀¹ tⁿ P_l(t) dt`, integrated numerically over the angle (Simpson's rule; exact to
    /// f32 precision for the exponents a scene allows).
    pub fn new(n: f32) -> PhongKernel {
        const STEPS: usize = 8192;
        let n = n as f64;
        let h = std::f64::consts::FRAC_PI_2 / STEPS as f64;
        let mut sums = [0.0f64; MAX_ORDER];
        for s in 0..=STEPS {
            let a = s as f64 * h;
            let w = if s == 0 || s == STEPS {
                1.0
            } else if s % 2 == 1 {
                4.0
            } else {
                2.0
            };
            let t = a.cos();
            // dt = sin α dα; the integrand is tⁿ P_l(t).
            let f = w * t.powf(n) * a.sin();
            let (mut p0, mut p1) = (1.0, t);
            sums[0] += f;
            if MAX_ORDER > 1 {
                sums[1] += f * t;
            }
            for (l, sum) in sums.iter_mut().enumerate().skip(2) {
                let p2 = ((2 * l - 1) as f64 * t * p1 - (l - 1) as f64 * p0) / l as f64;
                *sum += f * p2;
                p0 = p1;
                p1 = p2;
            }
        }
        PhongKernel {
            lambda: sums.map(|s| ((n + 2.0) * s * h / 3.0) as f32),
        }
    }

    /// The fewest bands whose truncated kernel keeps the lobe's reflection of any incident light within
    /// `tolerance`: the first band whose `λ_l` is below `tolerance · λ_0`; `None` when the lobe is too
    /// sharp for [`MAX_ORDER`] bands.
    pub fn order_for(&self, tolerance: f32) -> Option<usize> {
        (1..MAX_ORDER).find(|&l| self.lambda[l].abs() < tolerance * self.lambda[0])
    }
}

/// Light reflected by a zonal kernel about unit direction `r` from stored coefficients `g` of `order`
/// bands: `Σ_l λ_l Σ_m g_lm Y_lm(r)`.
pub fn reflect(g: &[Vec3], order: usize, kernel: &PhongKernel, r: Vec3) -> Vec3 {
    if order <= 4 {
        // The glossy texels' every read: no 100-value buffer to clear.
        let mut y = [0.0f32; 16];
        eval_low(order, r, &mut y);
        return bands(g, order, kernel, &y);
    }
    let mut y = [0.0f32; len(MAX_ORDER)];
    eval(order, r, &mut y);
    bands(g, order, kernel, &y)
}

/// `Σ_l λ_l Σ_m g_lm y_lm` over `order` bands.
fn bands(g: &[Vec3], order: usize, kernel: &PhongKernel, y: &[f32]) -> Vec3 {
    let mut out = Vec3::ZERO;
    for l in 0..order {
        let mut band = Vec3::ZERO;
        for i in l * l..(l + 1) * (l + 1) {
            band += g[i] * y[i];
        }
        out += kernel.lambda[l] * band;
    }
    out
}

#[cfg(test)]
mod tests {
    use super::*;
    use photon::sampling::Rng;

    fn random_dir(rng: &mut Rng) -> Vec3 {
        let z = 1.0 - 2.0 * rng.uniform();
        let phi = 2.0 * std::f32::consts::PI * rng.uniform();
        let s = (1.0 - z * z).max(0.0).sqrt();
        Vec3::new(s * phi.cos(), s * phi.sin(), z)
    }

    #[test]
    fn the_closed_forms_match_the_recurrence() {
        let mut rng = Rng::new(5);
        for _ in 0..100 {
            let d = random_dir(&mut rng);
            let (mut a, mut b) = ([0.0f32; 16], [0.0f32; 16]);
            eval_low(4, d, &mut a);
            eval_recurrence(4, d, &mut b);
            for i in 0..16 {
                assert!(
                    (a[i] - b[i]).abs() < 1e-5,
                    "Y{i}({d}): {} vs {}",
                    a[i],
                    b[i]
                );
            }
        }
    }

    #[test]
    fn the_basis_is_orthonormal() {
        let order = MAX_ORDER;
        let n = len(order);
        let mut gram = vec![0.0f64; n * n];
        let mut rng = Rng::new(7);
        let samples = 200_000;
        let mut y = vec![0.0f32; n];
        for _ in 0..samples {
            eval(order, random_dir(&mut rng), &mut y);
            for i in 0..n {
                for j in 0..n {
                    gram[i * n + j] += (y[i] * y[j]) as f64;
                }
            }
        }
        let scale = 4.0 * std::f64::consts::PI / samples as f64;
        for i in 0..n {
            for j in 0..n {
                let v = gram[i * n + j] * scale;
                let want = if i == j { 1.0 } else { 0.0 };
                assert!((v - want).abs() < 0.05, "<Y{i}, Y{j}> = {v}");
            }
        }
    }

    #[test]
    fn the_addition_theorem_holds() {
        // Σ_m Y_lm(a) Y_lm(b) = (2l+1)/(4π) P_l(a·b): conventions of sign cannot break it.
        let mut rng = Rng::new(3);
        let (a, b) = (random_dir(&mut rng), random_dir(&mut rng));
        let (mut ya, mut yb) = ([0.0f32; 100], [0.0f32; 100]);
        eval(MAX_ORDER, a, &mut ya);
        eval(MAX_ORDER, b, &mut yb);
        let t = a.dot(b) as f64;
        let (mut p0, mut p1) = (1.0f64, t);
        for l in 0..MAX_ORDER {
            let p = match l {
                0 => 1.0,
                1 => t,
                _ => {
                    let p2 = ((2 * l - 1) as f64 * t * p1 - (l - 1) as f64 * p0) / l as f64;
                    p0 = p1;
                    p1 = p2;
                    p2
                }
            };
            let sum: f64 = (l * l..(l + 1) * (l + 1))
                .map(|i| (ya[i] * yb[i]) as f64)
                .sum();
            let want = (2 * l + 1) as f64 / (4.0 * std::f64::consts::PI) * p;
            assert!((sum - want).abs() < 1e-4, "band {l}: {sum} vs {want}");
        }
    }

    #[test]
    fn the_phong_kernel_matches_its_closed_forms() {
        for n in [1.0f32, 10.0, 40.0, 225.0, 2000.0] {
            let k = PhongKernel::new(n);
            // λ_0 = (n+2)/(n+1), λ_1 = (n+2)/(n+2) = 1.
            let l0 = (n + 2.0) / (n + 1.0);
            assert!(
                (k.lambda[0] - l0).abs() < 1e-4 * l0,
                "n {n}: {:?}",
                k.lambda
            );
            assert!((k.lambda[1] - 1.0).abs() < 1e-4, "n {n}: {:?}", k.lambda);
            // Sharper lobes keep more of the high bands.
            assert!(k.lambda[9] > 0.0 || n < 40.0);
        }
        // The radiance cache serves the lobes whose kernel falls below half within 10 bands
        // (tolerance 0.5): up to about exponent 65, as the docs state it.
        let bands = |n: f32| PhongKernel::new(n).order_for(0.5);
        assert_eq!(
            [
                bands(10.0),
                bands(25.0),
                bands(40.0),
                bands(60.0),
                bands(70.0)
            ],
            [Some(4), Some(6), Some(8), Some(9), None]
        );
        assert!(PhongKernel::new(10.0).order_for(0.1).is_some());
        assert!(PhongKernel::new(5000.0).order_for(0.1).is_none());
    }

    #[test]
    fn reflecting_a_projected_field_matches_direct_integration() {
        // g(ω) = max(ω·z, 0)² · (1 + x) projected by Monte Carlo, reflected by a lobe of exponent 8
        // about r, against the lobe integrated over the same samples.
        let order = MAX_ORDER;
        let kernel = PhongKernel::new(8.0);
        let r = Vec3::new(0.3, 0.2, 0.93).normalize();
        let g = |w: Vec3| w.z.max(0.0).powi(2) * (1.0 + w.x);
        let mut coeffs = vec![Vec3::ZERO; len(order)];
        let mut rng = Rng::new(11);
        let (samples, mut direct) = (400_000, 0.0f64);
        let mut y = vec![0.0f32; len(order)];
        for _ in 0..samples {
            let w = random_dir(&mut rng);
            eval(order, w, &mut y);
            for (c, yi) in coeffs.iter_mut().zip(&y) {
                *c += Vec3::splat(g(w) * yi);
            }
            direct +=
                (g(w) * 10.0 / (2.0 * std::f32::consts::PI) * w.dot(r).max(0.0).powi(8)) as f64;
        }
        let scale = 4.0 * std::f32::consts::PI / samples as f32;
        coeffs.iter_mut().for_each(|c| *c *= scale);
        let direct = direct as f32 * scale;
        let got = reflect(&coeffs, order, &kernel, r).x;
        assert!((got - direct).abs() < 0.03 * direct, "{got} vs {direct}");
    }
}
