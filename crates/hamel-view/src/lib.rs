//! Animated 3D pages of simulated scenes (issue 60): one self-contained HTML file that plays
//! the motion offline, years later, from disk.
//!
//! **Job**: carry the 3D library inline. This first step vendors three.js: the core and the
//! orbit controls of three@0.187.0 from the npm registry, bundled by esbuild into one classic
//! script that sets `window.THREE` ([`THREE_JS`]), with its MIT licence ([`THREE_LICENSE`]),
//! which every page prints. `assets/three/build.sh` rebuilds the bundle from the registry
//! (reproducibly: same bytes); `assets/three/PIN` records the versions and the bundle's
//! SHA-256, which the tests check.
//!
//! [`poses`] places every frame of a mechanism in the world at a configuration (position and
//! unit quaternion) from the frames' own expressions, without computer algebra; [`shapes`]
//! gives a body without a shape the box or ellipsoid of its inertia.
//!
//! **Invariants**: no network at view time; the bundle is exactly the pinned one; poses are
//! the frames' definitions evaluated, checked against the ground contact of every wheel.

pub mod drawing;
pub mod motion;
pub mod page;
pub mod poses;
pub mod shapes;

pub use drawing::{DrawError, Drawing};
pub use motion::{Arrow, Motion, Series};
pub use page::Animation;

/// three.js (core and orbit controls) as one minified classic script setting `window.THREE`.
pub const THREE_JS: &str = include_str!("../assets/three/three.bundle.min.js");

/// three.js's licence (MIT), printed in every page that carries it.
pub const THREE_LICENSE: &str = include_str!("../assets/three/LICENSE");

/// The pin of the vendored bundle: `three VERSION`, `esbuild VERSION`, `sha256 HEX`.
pub const THREE_PIN: &str = include_str!("../assets/three/PIN");

/// The pinned three.js version.
pub fn three_version() -> &'static str {
    pinned("three")
}

/// The value of `key` in [`THREE_PIN`].
fn pinned(key: &str) -> &'static str {
    THREE_PIN
        .lines()
        .find_map(|l| l.strip_prefix(key)?.strip_prefix(' '))
        .expect("PIN names three, esbuild and sha256")
}

#[cfg(test)]
mod tests {
    use sha2::{Digest, Sha256};

    /// The committed bundle is the pinned one: a changed byte, or a rebuild with other
    /// versions without updating PIN, fails here.
    #[test]
    fn the_vendored_bundle_is_the_pinned_one() {
        let hash: String = Sha256::digest(super::THREE_JS.as_bytes())
            .iter()
            .map(|b| format!("{b:02x}"))
            .collect();
        assert_eq!(hash, super::pinned("sha256"));
        assert_eq!(super::three_version(), "0.187.0");
        // three's own revision number inside the bundle agrees with the pin.
        let revision = super::three_version().split('.').nth(1).unwrap();
        assert!(super::THREE_JS.contains(&format!("\"{revision}\"")));
        assert!(super::THREE_JS.contains("OrbitControls"));
        assert!(super::THREE_LICENSE.starts_with("The MIT License"));
    }
}
