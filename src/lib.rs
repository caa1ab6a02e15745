//! # superhelix
//!
//! The `superhelix` command's library face: every item of `superhelix-studies` (running
//! a scene, checking scenes and the studies and measurements) re-exported under
//! `superhelix::`, and the scene `run` takes without a scene file ([`DEFAULT_SCENE`]).
//! The command itself (`src/main.rs`, `src/cli/`) only parses arguments and calls the
//! library.
#![warn(missing_docs)]

pub use superhelix_studies::*;

/// The scene `superhelix run` uses without a scene file (`src/default_scene.toml`): a
/// full head of 100 wavy guides touching the head, neck and shoulders, with hair–hair
/// contacts, on keyframed head motion.
pub const DEFAULT_SCENE: &str = include_str!("default_scene.toml");

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn the_default_scene_is_a_full_head_with_bodies_and_contacts() {
        let setup = match parse_scene(DEFAULT_SCENE) {
            Ok(s) => s,
            Err(e) => panic!("{e}"),
        };
        assert_eq!(setup.strands.len(), 100);
        let names: Vec<&str> = setup.bodies.iter().map(|b| b.name.as_str()).collect();
        assert_eq!(names, ["head", "neck", "shoulders"]);
        let contacts = setup.contacts.as_ref().expect("[contacts]");
        assert!(contacts.hair_hair.is_some());
        assert!(matches!(setup.head, HeadMotion::Keyframes(_)));
        assert_eq!(check_scene(DEFAULT_SCENE), Ok(setup.clone()));
        assert_eq!(runtime::scene::step_count(&setup), 90);
    }
}
