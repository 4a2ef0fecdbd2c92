//! Problem-family TOML (a `builtin:NAME` base, or a path from the working
//! directory) → validated family; a family of at most 4 random obstacles
//! (more only cost time: each placement may try 100 poses) is sampled at
//! [`SAMPLES`] members, ids 0, 1, 2 with a run seed hashed from the input.
//!
//! Beyond "no panic", each sample keeps its obvious invariants: its id, its
//! stream seed ([`sample_seed`]) and name (`FAMILY#ID`); a start of the
//! robot's length, finite, and within the limits when the base start is;
//! the base's objects (moved, finite poses) and obstacles plus at most the
//! family's count of random ones, placed + skipped within it, every pose
//! finite and every shape valid; and the same (seed, id) gives the same
//! sample. Huge but finite values (±1e308 regions, 1e300 sizes, huge
//! jitter; seeds in `corpus/family_toml/huge_*.toml`) are refused while
//! the family is read, before any sampling.
#![no_main]

use libfuzzer_sys::fuzz_target;
use nalgebra::IsometryMatrix3;
use tandem::problem::{FamilySample, ProblemFamily, sample_seed};

/// Members sampled per family.
const SAMPLES: u64 = 3;

/// FNV-1a of the input: the run seed.
fn seed_of(data: &[u8]) -> u64 {
    data.iter().fold(0xCBF2_9CE4_8422_2325, |h, b| (h ^ u64::from(*b)).wrapping_mul(0x0100_0000_01B3))
}

fn finite_pose(pose: &IsometryMatrix3<f64>) -> bool {
    pose.translation.vector.iter().chain(pose.rotation.matrix().iter()).all(|v| v.is_finite())
}

fn check(family: &ProblemFamily, seed: u64, id: u64, sample: &FamilySample) {
    let base = &family.base;
    let problem = &sample.problem;
    assert_eq!(sample.id, id);
    assert_eq!(sample.seed, sample_seed(seed, id), "the stream seed of ({seed}, {id})");
    assert_eq!(problem.name, format!("{}#{id}", family.name));
    let robot = &problem.robot;
    assert_eq!(problem.start.len(), robot.nq(), "start length");
    assert!(problem.start.iter().all(|v| v.is_finite()), "start {:?}", problem.start);
    if base.robot.within_limits(&base.start) {
        assert!(robot.within_limits(&problem.start), "start {:?} leaves the limits", problem.start);
    }
    let (objects, obstacles) = (problem.scene.objects(), problem.scene.obstacles());
    assert_eq!(objects.len(), base.scene.objects().len(), "objects");
    for o in objects {
        assert!(finite_pose(&o.pose), "object {} at {:?}", o.name, o.pose);
    }
    let added = obstacles.len().checked_sub(base.scene.obstacles().len()).expect("the base's obstacles are kept");
    assert!(
        added + sample.skipped_obstacles <= family.max_obstacles(),
        "{added} placed, {} skipped",
        sample.skipped_obstacles
    );
    for o in obstacles {
        assert!(finite_pose(&o.pose), "obstacle {} at {:?}", o.name, o.pose);
        assert!(o.shape.validate().is_ok(), "obstacle {}: {:?}", o.name, o.shape);
        assert!(o.shape.bounding_radius().is_finite(), "obstacle {}: {:?}", o.name, o.shape);
    }
}

fuzz_target!(|data: &[u8]| {
    let Ok(text) = std::str::from_utf8(data) else { return };
    let Ok(family) = ProblemFamily::from_str_with(text, "<fuzz>", None) else { return };
    if family.max_obstacles() > 4 {
        return;
    }
    let seed = seed_of(data);
    for id in 0..SAMPLES {
        let Ok(sample) = family.sample(seed, id) else { return };
        check(&family, seed, id, &sample);
        if id == 0 {
            let again = family.sample(seed, id).expect("sampled once already");
            assert_eq!(again.problem.start, sample.problem.start, "the same (seed, id), another start");
            let poses = |s: &FamilySample| s.problem.scene.obstacles().iter().map(|o| o.pose).collect::<Vec<_>>();
            assert_eq!(poses(&again), poses(&sample), "the same (seed, id), other obstacles");
        }
    }
});
