//! The memory estimate (`runtime/src/memory_plan.rs`, docs/output.md) against the peak
//! resident memory (Linux's VmHWM) that `superhelix run` measures of itself and prints
//! beside the estimate, on a table of scenes: both engines, N = 2 to 50, body contacts,
//! hair–hair contact (a dense patch on a sphere, its pairs capped per sample, and a sparse
//! one; the dense one with the pair solve on both engines), electrostatics, render strands written to USD. Each must be within 25 % of its
//! peak.

mod support;

use support::{scratch, superhelix, text, write};

/// A patch of `count` strands of `n` elements (20 cm, wavy) on `engine`, one step, with
/// `extra` appended to the scene.
fn patch(engine: &str, count: [usize; 2], n: usize, extra: &str) -> String {
    format!(
        "[simulation]\nduration = 0.0333333\nengine = \"{engine}\"\n[[patches]]\ncount = [{}, {}]\nsize = [0.1, 0.1]\nlength = 0.2\nelements = {n}\npreset = \"wavy\"\ncenter = [0.0, 0.0, 0.101]\ndirection = [1.0, 0.0, 0.0]\n{extra}",
        count[0], count[1]
    )
}

/// "memory: P MB at peak (estimated E MB)" of a run's output: (P, E).
fn peak_and_estimate(said: &str) -> Option<(f64, f64)> {
    let line = said
        .lines()
        .find(|l| l.contains(" MB at peak (estimated "))?;
    let peak = line
        .strip_prefix("memory: ")?
        .split(' ')
        .next()?
        .parse()
        .ok()?;
    let estimate = line
        .split("(estimated ")
        .nth(1)?
        .split(' ')
        .next()?
        .parse()
        .ok()?;
    Some((peak, estimate))
}

#[cfg(target_os = "linux")]
#[test]
fn the_estimate_is_within_a_quarter_of_the_measured_peak() {
    let dir = scratch("memory-estimate");
    let sphere = "[[bodies]]\nshape = \"sphere\"\nradius = 0.1\ncenter = [0.0, 0.0, 0.0]\n[contacts]\nradius = 0.001\n";
    let charged =
        "[electrostatics]\nmethod = \"fmm\"\nparticle_density = 50000\ncharge_per_length = -1e-9\n";
    let render = "[render]\nstrands = 200000\n";
    let hair_hair = format!("{sphere}[contacts.hair_hair]\n");
    let coupled = format!("{hair_hair}coupling = \"pair\"\n");
    // a patch of strands standing up over the sphere's top (roots 15 mm above it), which
    // fall onto each other and the sphere
    let over = |scene: String| {
        scene
            .replace("direction = [1.0, 0.0, 0.0]", "direction = [0.0, 0.0, 1.0]")
            .replace("center = [0.0, 0.0, 0.101]", "center = [0.0, 0.0, 0.115]")
            .replace("0.0333333", "0.1")
    };
    let table: [(&str, String, &str); 13] = [
        ("runtime, N = 5", patch("runtime", [25, 40], 5, ""), "npy"),
        ("runtime, N = 20", patch("runtime", [10, 20], 20, ""), "npy"),
        ("runtime, N = 50", patch("runtime", [5, 10], 50, ""), "npy"),
        (
            "embedded, N = 5",
            patch("embedded", [50, 100], 5, ""),
            "npy",
        ),
        (
            "embedded, N = 20",
            patch("embedded", [40, 50], 20, ""),
            "npy",
        ),
        (
            "runtime, N = 10, body contacts",
            patch("runtime", [20, 25], 10, sphere),
            "npy",
        ),
        (
            "embedded, N = 5, body contacts",
            patch(
                "embedded",
                [100, 150],
                5,
                &format!("{sphere}predict = false\n"),
            ),
            "npy",
        ),
        (
            "runtime, N = 8, hair–hair, 500 strands on 1 dm²",
            // 0.1 s: the pairs' lists reach their size once the strands have met (the
            // peak of one frame is about a fifth lower)
            over(patch("runtime", [20, 25], 8, &hair_hair)),
            "npy",
        ),
        (
            "runtime, N = 8, hair–hair coupled (pair), 500 strands on 1 dm²",
            over(patch("runtime", [20, 25], 8, &coupled)),
            "npy",
        ),
        (
            "embedded, N = 8, hair–hair coupled (pair), 500 strands on 1 dm²",
            over(patch("embedded", [20, 25], 8, &coupled)),
            "npy",
        ),
        (
            "runtime, N = 5, hair–hair, 144 strands on 1 dm²",
            over(patch("runtime", [12, 12], 5, &hair_hair)),
            "npy",
        ),
        (
            "electrostatics, 200,000 particles",
            patch("auto", [5, 4], 5, charged),
            "npy",
        ),
        (
            "200,000 render strands to USD",
            patch("auto", [10, 10], 5, render),
            "npy,usda",
        ),
    ];
    for (k, (name, scene, formats)) in table.iter().enumerate() {
        let path = write(&dir, &format!("s{k}.toml"), scene);
        let out = dir.join(format!("out{k}"));
        let o = superhelix(&[
            "run",
            &path.to_string_lossy(),
            "--out",
            &out.to_string_lossy(),
            "--format",
            formats,
        ]);
        let said = text(&o);
        assert!(o.status.success(), "{name}:\n{said}");
        let (peak, estimate) =
            peak_and_estimate(&said).unwrap_or_else(|| panic!("{name}: no memory line in\n{said}"));
        eprintln!("{name}: peak {peak} MB, estimated {estimate} MB");
        // the strands, particles or points, not the 10 MB of the process, make the peak
        assert!(
            peak > 30.0,
            "{name}: a peak of {peak} MB tests the process alone"
        );
        assert!(
            (estimate / peak - 1.0).abs() <= 0.25,
            "{name}: estimated {estimate} MB against a peak of {peak} MB"
        );
    }
}
