//! SRDF parsing against the MotionBenchMaker Panda (problems/motionbenchmaker)
//! and the embedded Panda, with line-numbered errors.

use std::sync::Arc;
use tandem::robot::{MeshSearchPath, RobotDescription, RobotError, RobotModel, Srdf};

fn mbm(file: &str) -> std::path::PathBuf {
    std::path::PathBuf::from(env!("CARGO_MANIFEST_DIR")).join("problems/motionbenchmaker").join(file)
}

#[test]
fn motion_bench_maker_panda_srdf_parses_and_matches_the_spherized_urdf() {
    let srdf = Srdf::from_srdf_file(mbm("panda.srdf")).unwrap();
    assert_eq!(srdf.disabled_pairs.len(), 34);
    assert!(srdf.is_disabled("panda_link1", "panda_link0") && srdf.is_disabled("panda_link0", "panda_link1"));
    let ready = srdf.group_state("ready").unwrap();
    assert_eq!(ready.group, "panda_arm");
    assert_eq!(ready.values.len(), 7);
    let robot =
        Arc::new(RobotDescription::from_urdf_file(mbm("panda_spherized.urdf"), &MeshSearchPath::default()).unwrap());
    srdf.check_against(&robot).unwrap();
    let arm = RobotModel::builder(robot).selection(srdf.joint_selection("panda_arm").unwrap()).build().unwrap();
    assert_eq!(arm.nq(), 7);
    // The embedded Panda has the same link names.
    srdf.check_against(&RobotDescription::panda()).unwrap();
}

#[test]
fn srdf_errors_name_the_line() {
    let srdf = Srdf::from_srdf_str(
        "<robot name=\"p\">\n<disable_collisions link1=\"panda_link1\" link2=\"panda_lnk2\"/>\n</robot>",
    )
    .unwrap();
    let e = srdf.check_against(&RobotDescription::panda()).unwrap_err();
    assert!(matches!(e, RobotError::InvalidSrdf { .. }), "{e}");
    let text = e.to_string();
    assert!(
        text.contains("<string>:2") && text.contains("panda_lnk2") && text.contains("did you mean panda_link2"),
        "{text}"
    );
    let e = Srdf::from_srdf_str(
        "<robot>\n<group_state name=\"s\" group=\"g\"><joint name=\"j\" value=\"abc\"/></group_state></robot>",
    )
    .unwrap_err();
    assert!(e.to_string().contains(":2") && e.to_string().contains("'abc'"), "{e}");
    let e = Srdf::from_srdf_str("<robot><disable_collisions link1=\"a\"/></robot>").unwrap_err();
    assert!(e.to_string().contains("link2"), "{e}");
    assert!(matches!(Srdf::from_srdf_str("<robot>"), Err(RobotError::MalformedXml { .. })));
}
