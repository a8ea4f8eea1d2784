//! Between two scenes of a sequence (a mesh or a light changed): what changed, from where each mesh
//! was, and the atlas the scene before leaves to the next one's first frame.

use super::*;

impl Sequence {
    /// Frame `f` of `anim` begins `scene` (a mesh or a light changed since frame `f − 1`): what
    /// changed, from where each mesh was.
    pub(super) fn next_scene(&mut self, anim: &Animation, scene: &Scene, f: u32) {
        let mut moved = Vec::new();
        let mut rigid = Vec::new();
        // A mesh that emits and moved is a light that changed.
        let mut lights = anim.lights_changed(f - 1, f);
        for m in anim.moved_meshes(f - 1, f) {
            lights |= scene.mesh_emits(m);
            if let (Some(before), Some(after)) = (
                self.mesh_spheres.get(m).copied().flatten(),
                scene.mesh_sphere(m),
            ) {
                let step = match (
                    scene::mesh_transform(anim, f - 1, m),
                    scene::mesh_transform(anim, f, m),
                ) {
                    (Some(t0), Some(t1)) => Some(t1 * t0.inverse()),
                    _ => None,
                };
                moved.push(Moved::new(before, after, step));
                if let Some(step) = step {
                    rigid.push(Rigid {
                        mesh: m,
                        before,
                        step,
                    });
                }
            }
        }
        self.change = Some(SceneChange {
            moved,
            rigid,
            lights,
        });
        self.atlas_next = None;
    }

    /// `scene`'s last frame is done: its atlas (with the temporal cache) and where its meshes were
    /// are kept for the next scene's first frame.
    pub(super) fn end_scene(&mut self, maps: Option<PhotonData>, scene: &Scene) {
        let temporal = self.photon_paths.is_some();
        let next = self.atlas_next.take();
        self.atlas_before = maps.filter(|_| temporal).and_then(|p| {
            let (maps, atlas) = p.into_maps_and_atlas();
            let keys = next.or_else(|| Some(PhotonKeys::of(maps.global.as_ref()?.photons())))?;
            Some(AtlasBefore {
                atlas: atlas?,
                keys,
            })
        });
        self.mesh_spheres = (0..scene.mesh_ranges.len())
            .map(|m| scene.mesh_sphere(m))
            .collect();
    }
}
