//! Animated 3D pages of simulated scenes (issue 60): one self-contained HTML file that plays
//! the motion offline, years later, from disk (`hamel simulate SCENE --animate PAGE.html`;
//! docs/animate.md).
//!
//! **Job**: from a mechanism (`hamel_bodies::Mechanism`) and its motions (configurations at
//! output times), make the page. [`poses`] places every frame in the world at a configuration
//! (position and unit quaternion) from the frames' own expressions; [`drawing`] decides what is
//! drawn, fixed in time (wheels as disks, blades as plates, the model's `[shapes]`, other
//! bodies as their inertia's ellipsoid from [`shapes`]); [`motion`] holds a run's poses,
//! contact points, plotted outputs and force arrows at its output times; [`page`] writes the
//! HTML with three.js inline ([`THREE_JS`]: the core and the orbit controls of three@0.187.0
//! from the npm registry, bundled by esbuild into one classic script that sets
//! `window.THREE`; its MIT licence, [`THREE_LICENSE`], is printed in every page).
//! `assets/three/build.sh` rebuilds the bundle from the registry (reproducibly: same bytes);
//! `assets/three/PIN` records the versions and the bundle's SHA-256, which the tests check.
//!
//! **Inputs**: a mechanism, parameter values, times and whole configurations (every
//! coordinate), optionally outputs and contact forces. **Output**: [`Animation::html`].
//!
//! **Invariants**: no computer algebra; no network at view time; the bundle is exactly the
//! pinned one; the numbers cross into the page exactly (base64 float64), so the page's
//! `window.hamel.poseAt` equals [`poses::poses`] at the output times; text from a model or
//! scene enters the page as escaped JSON and as text, never as markup (SECURITY.md).

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
