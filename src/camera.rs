//! Pinhole camera with a vertical field of view and a box pixel filter.

use glam::Vec3;

/// A camera's pixel size at each distance: how many of its pixels a disc on a surface spans.
#[derive(Clone, Copy, Debug)]
pub struct PixelSpan {
    eye: Vec3,
    forward: Vec3,
    /// A pixel's height on the image plane at distance 1.
    pixel: f32,
}

impl PixelSpan {
    /// The world size of a pixel at `distance` along `dir`, on a surface at `cos_theta` to it.
    pub fn pixel_world(&self, dir: Vec3, distance: f32, cos_theta: f32) -> f32 {
        let along_axis = distance * self.forward.dot(dir).abs().max(1e-3);
        self.pixel * along_axis / cos_theta.abs().max(0.05).sqrt()
    }

    /// The pixels a disc of radius `r` at `p` (normal `n`) spans; a disc at the eye spans them all.
    pub fn of(&self, p: Vec3, n: Vec3, r: f32) -> f32 {
        let to = p - self.eye;
        let dist = to.length();
        if !(dist > 0.0) {
            return f32::INFINITY;
        }
        let dir = to / dist;
        r / self.pixel_world(dir, dist, n.dot(dir))
    }
}

#[derive(Clone, Debug)]
pub struct Camera {
    pub eye: Vec3,
    forward: Vec3,
    right: Vec3,
    up: Vec3,
    /// tan(fov/2): half the image-plane height at distance 1.
    tan_half: f32,
    pub width: u32,
    pub height: u32,
}

impl Camera {
    /// `up` must not be parallel to `target − eye` (checked by the scene loader). The frame is built in
    /// f64: `target − eye` of two finite f32 points, or its length squared, may overflow f32.
    pub fn new(eye: Vec3, target: Vec3, up: Vec3, fov_deg: f32, width: u32, height: u32) -> Camera {
        let forward = (target.as_dvec3() - eye.as_dvec3()).normalize();
        let right = forward.cross(up.as_dvec3()).normalize();
        let (up, forward, right) = (
            right.cross(forward).as_vec3(),
            forward.as_vec3(),
            right.as_vec3(),
        );
        Camera {
            eye,
            forward,
            right,
            up,
            tan_half: (fov_deg.to_radians() * 0.5).tan(),
            width,
            height,
        }
    }

    /// Whether `other` sees exactly what this camera sees.
    pub fn same_view(&self, other: &Camera) -> bool {
        self.eye == other.eye
            && self.forward == other.forward
            && self.up == other.up
            && self.tan_half == other.tan_half
            && (self.width, self.height) == (other.width, other.height)
    }

    /// Unit viewing direction.
    pub fn forward(&self) -> Vec3 {
        self.forward
    }

    /// Unit image-up direction (orthogonal to `forward`).
    pub fn up_vector(&self) -> Vec3 {
        self.up
    }

    /// Vertical field of view in degrees.
    pub fn fov_deg(&self) -> f32 {
        2.0 * self.tan_half.atan().to_degrees()
    }

    pub fn with_resolution(&self, width: u32, height: u32) -> Camera {
        Camera {
            width,
            height,
            ..self.clone()
        }
    }

    /// Primary ray through image position (x, y) in pixels from the top-left corner (continuous).
    pub fn ray(&self, x: f32, y: f32) -> Vec3 {
        let aspect = self.width as f32 / self.height as f32;
        let sx = (2.0 * x / self.width as f32 - 1.0) * self.tan_half * aspect;
        let sy = (1.0 - 2.0 * y / self.height as f32) * self.tan_half;
        (self.forward + sx * self.right + sy * self.up).normalize()
    }

    /// The angle one pixel subtends at the image's centre (radians, small-angle).
    pub fn pixel_angle(&self) -> f32 {
        2.0 * self.tan_half / self.height as f32
    }

    /// World-space width of one pixel at `distance` along a ray, on a surface seen at `cos_theta` to
    /// its normal (the pixel footprint projected onto the tangent plane, along its longer axis).
    pub fn pixel_world(&self, dir: Vec3, distance: f32, cos_theta: f32) -> f32 {
        self.pixel_span().pixel_world(dir, distance, cos_theta)
    }

    /// What measures world sizes in this camera's pixels, without the camera.
    pub fn pixel_span(&self) -> PixelSpan {
        PixelSpan {
            eye: self.eye,
            forward: self.forward,
            pixel: 2.0 * self.tan_half / self.height as f32,
        }
    }

    /// Pixel coordinates of a world point, if in front of the camera.
    pub fn project(&self, p: Vec3) -> Option<(f32, f32)> {
        let d = p - self.eye;
        let z = d.dot(self.forward);
        if z <= 0.0 {
            return None;
        }
        let aspect = self.width as f32 / self.height as f32;
        let sx = d.dot(self.right) / (z * self.tan_half * aspect);
        let sy = d.dot(self.up) / (z * self.tan_half);
        Some((
            (sx + 1.0) * 0.5 * self.width as f32,
            (1.0 - sy) * 0.5 * self.height as f32,
        ))
    }
}
