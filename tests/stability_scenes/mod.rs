//! Scene generators for the failure-case stability suite (`tests/stability.rs`): small OBJ text built
//! from quads, boxes and spheres, and a scene-file builder. Everything is written into a temp dir.
#![allow(dead_code)]

use glam::Vec3;

/// OBJ text under construction: positions, optional normals, faces grouped by material.
#[derive(Default)]
pub struct Obj {
    v: Vec<Vec3>,
    vn: Vec<Vec3>,
    body: String,
    mat: String,
}

impl Obj {
    pub fn new() -> Obj {
        Obj::default()
    }

    /// Adds a position, returns its 1-based index.
    pub fn vertex(&mut self, p: Vec3) -> usize {
        self.v.push(p);
        self.v.len()
    }

    /// Adds a normal (not normalised here, so tests can write odd ones), returns its 1-based index.
    pub fn normal(&mut self, n: Vec3) -> usize {
        self.vn.push(n);
        self.vn.len()
    }

    fn use_mat(&mut self, mat: &str) {
        if self.mat != mat {
            self.body += &format!("usemtl {mat}\n");
            self.mat = mat.to_string();
        }
    }

    /// A face over existing position indices, without normals.
    pub fn face(&mut self, mat: &str, idx: &[usize]) {
        self.use_mat(mat);
        let s: Vec<String> = idx.iter().map(|i| i.to_string()).collect();
        self.body += &format!("f {}\n", s.join(" "));
    }

    /// A face over existing (position, normal) index pairs.
    pub fn face_n(&mut self, mat: &str, idx: &[(usize, usize)]) {
        self.use_mat(mat);
        let s: Vec<String> = idx.iter().map(|(v, n)| format!("{v}//{n}")).collect();
        self.body += &format!("f {}\n", s.join(" "));
    }

    /// A quad with its own four vertices; counter-clockwise seen from the side it faces.
    pub fn quad(&mut self, mat: &str, p: [Vec3; 4]) {
        let i: Vec<usize> = p.iter().map(|&q| self.vertex(q)).collect();
        self.face(mat, &i);
    }

    /// An axis-aligned box from `lo` to `hi`, faces wound outward (`inward` = false) or inward.
    /// `skip` names faces to leave out: "-x", "+x", "-y", "+y", "-z", "+z".
    pub fn cuboid(&mut self, mat: &str, lo: Vec3, hi: Vec3, inward: bool, skip: &[&str]) {
        let c = |x: bool, y: bool, z: bool| {
            Vec3::new(
                if x { hi.x } else { lo.x },
                if y { hi.y } else { lo.y },
                if z { hi.z } else { lo.z },
            )
        };
        // Each face counter-clockwise seen from outside.
        let faces = [
            (
                "-x",
                [
                    c(false, false, false),
                    c(false, false, true),
                    c(false, true, true),
                    c(false, true, false),
                ],
            ),
            (
                "+x",
                [
                    c(true, false, true),
                    c(true, false, false),
                    c(true, true, false),
                    c(true, true, true),
                ],
            ),
            (
                "-y",
                [
                    c(false, false, false),
                    c(true, false, false),
                    c(true, false, true),
                    c(false, false, true),
                ],
            ),
            (
                "+y",
                [
                    c(false, true, true),
                    c(true, true, true),
                    c(true, true, false),
                    c(false, true, false),
                ],
            ),
            (
                "-z",
                [
                    c(true, false, false),
                    c(false, false, false),
                    c(false, true, false),
                    c(true, true, false),
                ],
            ),
            (
                "+z",
                [
                    c(false, false, true),
                    c(true, false, true),
                    c(true, true, true),
                    c(false, true, true),
                ],
            ),
        ];
        for (name, mut q) in faces {
            if skip.contains(&name) {
                continue;
            }
            if inward {
                q.reverse();
            }
            self.quad(mat, q);
        }
    }

    /// A UV sphere with smooth per-vertex normals (outward).
    pub fn sphere(&mut self, mat: &str, centre: Vec3, r: f32, nu: usize, nv: usize) {
        let mut idx = vec![vec![(0usize, 0usize); nu]; nv + 1];
        for (j, row) in idx.iter_mut().enumerate() {
            let th = std::f32::consts::PI * j as f32 / nv as f32;
            for (i, slot) in row.iter_mut().enumerate() {
                let ph = 2.0 * std::f32::consts::PI * i as f32 / nu as f32;
                let n = Vec3::new(th.sin() * ph.cos(), th.cos(), th.sin() * ph.sin());
                *slot = (self.vertex(centre + r * n), self.normal(n));
            }
        }
        for j in 0..nv {
            for i in 0..nu {
                let (a, b) = (idx[j][i], idx[j][(i + 1) % nu]);
                let (c, d) = (idx[j + 1][(i + 1) % nu], idx[j + 1][i]);
                if j > 0 {
                    self.face_n(mat, &[a, b, c]);
                }
                if j + 1 < nv {
                    self.face_n(mat, &[a, c, d]);
                }
            }
        }
    }

    /// The OBJ text, referencing `mtllib`.
    pub fn text(&self, mtllib: &str) -> String {
        let mut s = format!("mtllib {mtllib}\n");
        for p in &self.v {
            s += &format!("v {} {} {}\n", p.x, p.y, p.z);
        }
        for n in &self.vn {
            s += &format!("vn {} {} {}\n", n.x, n.y, n.z);
        }
        s + &self.body
    }
}

pub fn v(x: f32, y: f32, z: f32) -> Vec3 {
    Vec3::new(x, y, z)
}

/// MTL text: diffuse walls (albedo 0.6), a diffuse red and green, a light, a mirror and glass.
pub const MTL: &str = "newmtl wall
Kd 0.6 0.6 0.6
newmtl red
Kd 0.6 0.1 0.1
newmtl green
Kd 0.1 0.6 0.1
newmtl light
Kd 0 0 0
Ke 10 10 10
newmtl mirror
Kd 0 0 0
Ks 0.9 0.9 0.9
illum 3
newmtl glass
Kd 0 0 0
Ni 1.5
illum 7
";

/// The open-front room of `tests/common` (x, z ∈ [−1, 1], y ∈ [0, 2], the +z wall missing) with red and
/// green side walls and a 0.5 × 0.5 ceiling light of radiance 10 facing down.
pub fn open_room(o: &mut Obj) {
    o.cuboid(
        "wall",
        v(-1.0, 0.0, -1.0),
        v(1.0, 2.0, 1.0),
        true,
        &["-x", "+x", "+z"],
    );
    o.quad(
        "red",
        [
            v(-1.0, 0.0, 1.0),
            v(-1.0, 0.0, -1.0),
            v(-1.0, 2.0, -1.0),
            v(-1.0, 2.0, 1.0),
        ],
    );
    o.quad(
        "green",
        [
            v(1.0, 0.0, -1.0),
            v(1.0, 0.0, 1.0),
            v(1.0, 2.0, 1.0),
            v(1.0, 2.0, -1.0),
        ],
    );
    ceiling_light(o, 0.25);
}

/// A square emitter of half-size `h` just below the ceiling, facing down.
pub fn ceiling_light(o: &mut Obj, h: f32) {
    o.quad(
        "light",
        [
            v(-h, 1.99, -h),
            v(h, 1.99, -h),
            v(h, 1.99, h),
            v(-h, 1.99, h),
        ],
    );
}

/// The open room of [`open_room`] broken in every way a mesh can be while meaning the same surfaces
/// (surfaces reflect on both sides): zero-area triangles, duplicated vertices, a wall wound the other way,
/// normals pointing out of the room, per-vertex normals that cancel, walls without normals.
pub fn broken_room(o: &mut Obj) {
    // Floor: two triangles sharing duplicated vertices, plus three zero-area ones.
    let f: Vec<usize> = [
        v(-1.0, 0.0, 1.0),
        v(1.0, 0.0, 1.0),
        v(1.0, 0.0, -1.0),
        v(-1.0, 0.0, -1.0),
    ]
    .iter()
    .map(|&p| o.vertex(p))
    .collect();
    let g: Vec<usize> = [v(-1.0, 0.0, 1.0), v(1.0, 0.0, -1.0)]
        .iter()
        .map(|&p| o.vertex(p))
        .collect();
    o.face("wall", &[f[0], f[1], f[2]]);
    o.face("wall", &[g[0], g[1], f[3]]);
    o.face("wall", &[f[0], f[0], f[1]]);
    o.face("wall", &[f[0], g[0], f[2]]);
    let mid = o.vertex(v(0.0, 0.0, 0.0));
    o.face("wall", &[f[0], mid, f[2]]);
    // Back wall wound clockwise (facing out of the room).
    o.quad(
        "wall",
        [
            v(-1.0, 0.0, -1.0),
            v(-1.0, 2.0, -1.0),
            v(1.0, 2.0, -1.0),
            v(1.0, 0.0, -1.0),
        ],
    );
    // Ceiling with normals pointing up, out of the room.
    let up = o.normal(v(0.0, 1.0, 0.0));
    let c: Vec<usize> = [
        v(-1.0, 2.0, 1.0),
        v(1.0, 2.0, 1.0),
        v(1.0, 2.0, -1.0),
        v(-1.0, 2.0, -1.0),
    ]
    .iter()
    .map(|&p| o.vertex(p))
    .collect();
    o.face_n("wall", &[(c[0], up), (c[1], up), (c[2], up), (c[3], up)]);
    // Left wall: per-vertex normals half in, half out.
    let (pin, pout) = (o.normal(v(1.0, 0.0, 0.0)), o.normal(v(-1.0, 0.0, 0.0)));
    let l: Vec<usize> = [
        v(-1.0, 0.0, 1.0),
        v(-1.0, 0.0, -1.0),
        v(-1.0, 2.0, -1.0),
        v(-1.0, 2.0, 1.0),
    ]
    .iter()
    .map(|&p| o.vertex(p))
    .collect();
    o.face_n("red", &[(l[0], pin), (l[1], pout), (l[2], pout)]);
    o.face_n("red", &[(l[0], pin), (l[2], pout), (l[3], pin)]);
    // Right wall without normals, over a duplicate of its first corner.
    let r: Vec<usize> = [
        v(1.0, 0.0, -1.0),
        v(1.0, 0.0, 1.0),
        v(1.0, 2.0, 1.0),
        v(1.0, 2.0, -1.0),
        v(1.0, 0.0, -1.0),
    ]
    .iter()
    .map(|&p| o.vertex(p))
    .collect();
    o.face("green", &[r[0], r[1], r[2]]);
    o.face("green", &[r[4], r[2], r[3]]);
    ceiling_light(o, 0.25);
}

/// Scene-file text: a camera, one mesh `scene.obj`, then `extra` (lights, `[render…]` tables).
pub fn toml(eye: Vec3, target: Vec3, fov: f32, (w, h): (u32, u32), extra: &str) -> String {
    format!(
        "version = 1\n[camera]\neye = [{}, {}, {}]\ntarget = [{}, {}, {}]\nfov = {fov}\nwidth = {w}\nheight = {h}\n\n\
         [[mesh]]\nobj = \"scene.obj\"\n\n{extra}\n",
        eye.x, eye.y, eye.z, target.x, target.y, target.z
    )
}

/// The camera of the open-front room: outside the missing wall, looking at the back wall.
pub fn room_toml(extra: &str) -> String {
    toml(v(0.0, 1.0, 3.0), v(0.0, 1.0, 0.0), 45.0, (32, 32), extra)
}

/// The `newmtl` blocks of `mtl` that `obj` uses. An unused mirror or glass would still make the renderer
/// chase a caustic map (`Scene::has_specular` looks at every material), costing 2M photon paths.
pub fn used_materials(obj: &Obj, mtl: &str) -> String {
    let used: Vec<&str> = obj
        .body
        .lines()
        .filter_map(|l| l.strip_prefix("usemtl "))
        .collect();
    mtl.split_inclusive('\n')
        .fold((String::new(), false), |(mut out, keep), line| {
            let keep = match line.strip_prefix("newmtl ") {
                Some(name) => used.contains(&name.trim()),
                None => keep,
            };
            if keep {
                out.push_str(line);
            }
            (out, keep)
        })
        .0
}

/// A point light sealed in a closed diffuse box (bottom at `y0`) over a floor at y = 0, seen from outside.
pub fn sealed_box_scene(y0: f32, extra: &str) -> tempfile::TempDir {
    let mut o = Obj::new();
    o.quad(
        "wall",
        [
            v(-2.0, 0.0, 2.0),
            v(2.0, 0.0, 2.0),
            v(2.0, 0.0, -2.0),
            v(-2.0, 0.0, -2.0),
        ],
    );
    o.cuboid("wall", v(-0.5, y0, -0.5), v(0.5, y0 + 1.0, 0.5), false, &[]);
    let light = format!(
        "[[light]]\ntype = \"point\"\nposition = [0.0, {}, 0.0]\nintensity = [50.0, 50.0, 50.0]\n\n",
        y0 + 0.5
    );
    write(
        &o,
        MTL,
        &toml(
            v(1.5, 1.8, 2.5),
            v(0.0, 0.4, 0.0),
            45.0,
            (32, 32),
            &format!("{light}{extra}"),
        ),
    )
}

/// The open room with its mesh scaled by `s` and the camera scaled with it.
pub fn scaled_room(s: f32, extra: &str) -> tempfile::TempDir {
    let mut o = Obj::new();
    open_room(&mut o);
    let t = toml(
        v(0.0, 1.0, 3.0) * s,
        v(0.0, 1.0, 0.0) * s,
        45.0,
        (32, 32),
        extra,
    );
    write(
        &o,
        MTL,
        &t.replace(
            "obj = \"scene.obj\"\n",
            &format!("obj = \"scene.obj\"\nscale = {s:e}\n"),
        ),
    )
}

/// A temp dir holding `scene.obj`, `scene.mtl` (the materials it uses) and `scene.toml`.
pub fn write(obj: &Obj, mtl: &str, toml: &str) -> tempfile::TempDir {
    let dir = tempfile::tempdir().expect("temp dir");
    std::fs::write(dir.path().join("scene.obj"), obj.text("scene.mtl")).expect("write obj");
    std::fs::write(dir.path().join("scene.mtl"), used_materials(obj, mtl)).expect("write mtl");
    std::fs::write(dir.path().join("scene.toml"), toml).expect("write toml");
    dir
}
