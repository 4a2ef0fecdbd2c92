//! Every kind of bad input gets its own typed error naming the file, the
//! element, the line and the value — never a panic.

use std::io::Write;
use tandem::robot::{KinematicsWorkspace, MeshSearchPath, RobotDescription, RobotError, RobotModel};

const GOOD_JOINT: &str = r#"<joint name="j1" type="revolute"><parent link="base"/><child link="arm"/>
    <axis xyz="0 0 1"/><limit lower="-1" upper="1" velocity="2" effort="5"/></joint>"#;

fn robot(body: &str) -> String {
    format!("<?xml version=\"1.0\"?>\n<robot name=\"r\">\n{body}\n</robot>\n")
}

fn parse(text: &str) -> Result<RobotDescription, RobotError> {
    RobotDescription::from_urdf_str(text, &MeshSearchPath::default())
}

fn line_of(e: &RobotError) -> Option<u32> {
    use RobotError::*;
    match e {
        MalformedXml { at, .. }
        | InvalidUrdf { at, .. }
        | UnknownJointType { at, .. }
        | UnsupportedJointType { at, .. }
        | MissingLink { at, .. }
        | DuplicateName { at, .. }
        | KinematicLoop { at, .. }
        | InvalidLimits { at, .. }
        | InvalidValue { at, .. }
        | ZeroAxis { at, .. }
        | InvalidMimic { at, .. }
        | MeshNotFound { at, .. } => at.line,
        _ => None,
    }
}

#[test]
fn malformed_xml_names_the_line() {
    let e = parse("<robot name=\"r\">\n<link name=\"a\">\n</robot>").unwrap_err();
    assert!(matches!(e, RobotError::MalformedXml { .. }), "{e}");
    assert_eq!(line_of(&e), Some(3), "{e}");
    assert!(e.to_string().contains("<string>:3"), "{e}");
}

#[test]
fn root_element_must_be_robot() {
    let e = parse("<model name=\"x\"/>").unwrap_err();
    assert!(matches!(e, RobotError::InvalidUrdf { .. }) && e.to_string().contains("<model>"), "{e}");
}

#[test]
fn joint_naming_a_missing_link() {
    let text = robot(&format!("<link name=\"base\"/>\n{}", GOOD_JOINT));
    let e = parse(&text).unwrap_err();
    match &e {
        RobotError::MissingLink { joint, link, role, .. } => {
            assert_eq!((joint.as_str(), link.as_str(), *role), ("j1", "arm", "child"));
        }
        other => panic!("unexpected {other}"),
    }
    assert_eq!(line_of(&e), Some(4));
}

#[test]
fn kinematic_loop_is_detected() {
    // Two joints give link "arm" two parents.
    let text = robot(&format!(
        "<link name=\"base\"/><link name=\"arm\"/>\n{GOOD_JOINT}\n<joint name=\"j2\" type=\"fixed\"><parent link=\"base\"/><child link=\"arm\"/></joint>"
    ));
    let e = parse(&text).unwrap_err();
    assert!(matches!(e, RobotError::KinematicLoop { .. }) && e.to_string().contains("j2"), "{e}");
    // A cycle a → b → a disconnected from the root.
    let text = robot(
        "<link name=\"base\"/><link name=\"a\"/><link name=\"b\"/>\n\
         <joint name=\"ab\" type=\"fixed\"><parent link=\"a\"/><child link=\"b\"/></joint>\n\
         <joint name=\"ba\" type=\"fixed\"><parent link=\"b\"/><child link=\"a\"/></joint>",
    );
    let e = parse(&text).unwrap_err();
    assert!(matches!(e, RobotError::KinematicLoop { .. }), "{e}");
}

#[test]
fn two_roots_are_named() {
    let e = parse(&robot("<link name=\"a\"/><link name=\"b\"/>")).unwrap_err();
    match e {
        RobotError::MultipleRoots { roots, .. } => assert_eq!(roots, vec!["a", "b"]),
        other => panic!("unexpected {other}"),
    }
}

#[test]
fn unknown_and_unsupported_joint_types() {
    let text = robot(
        "<link name=\"base\"/><link name=\"arm\"/>\n<joint name=\"h\" type=\"hinge\"><parent link=\"base\"/><child link=\"arm\"/></joint>",
    );
    let e = parse(&text).unwrap_err();
    assert!(matches!(&e, RobotError::UnknownJointType { joint_type, .. } if joint_type == "hinge"), "{e}");
    assert_eq!(line_of(&e), Some(4));
    let text = robot(
        "<link name=\"base\"/><link name=\"arm\"/>\n<joint name=\"f\" type=\"floating\"><parent link=\"base\"/><child link=\"arm\"/></joint>",
    );
    let e = parse(&text).unwrap_err();
    assert!(matches!(e, RobotError::UnsupportedJointType { .. }), "{e}");
}

#[test]
fn lower_limit_above_upper() {
    let text = robot(
        "<link name=\"base\"/><link name=\"arm\"/>\n<joint name=\"j1\" type=\"revolute\"><parent link=\"base\"/><child link=\"arm\"/>\
         <axis xyz=\"0 0 1\"/><limit lower=\"1.5\" upper=\"-1\" velocity=\"2\" effort=\"5\"/></joint>",
    );
    let e = parse(&text).unwrap_err();
    match &e {
        RobotError::InvalidLimits { joint, lower, upper, .. } => {
            assert_eq!((joint.as_str(), *lower, *upper), ("j1", 1.5, -1.0));
        }
        other => panic!("unexpected {other}"),
    }
    assert_eq!(line_of(&e), Some(4));
}

#[test]
fn zero_axis_and_non_finite_numbers() {
    let text = robot(&format!("<link name=\"base\"/><link name=\"arm\"/>\n{}", GOOD_JOINT.replace("0 0 1", "0 0 0")));
    assert!(matches!(parse(&text).unwrap_err(), RobotError::ZeroAxis { .. }));
    let text = robot(&format!(
        "<link name=\"base\"/><link name=\"arm\"/>\n{}",
        GOOD_JOINT.replace("<axis", "<origin xyz=\"0 NaN 0\"/><axis")
    ));
    let e = parse(&text).unwrap_err();
    assert!(matches!(&e, RobotError::InvalidValue { field, .. } if *field == "origin y"), "{e}");
    let text = robot("<link name=\"base\"><collision><geometry><sphere radius=\"-1\"/></geometry></collision></link>");
    let e = parse(&text).unwrap_err();
    assert!(matches!(&e, RobotError::InvalidValue { field, .. } if *field == "sphere radius"), "{e}");
}

#[test]
fn duplicate_names() {
    let e = parse(&robot("<link name=\"a\"/>\n<link name=\"a\"/>")).unwrap_err();
    assert!(matches!(e, RobotError::DuplicateName { kind: "link", .. }), "{e}");
}

#[test]
fn mimic_of_unknown_joint_is_ignored_with_a_warning_and_cycles_are_errors() {
    // urdfdom and Pinocchio ignore such mimics; tandem does too, but says so.
    let text = robot(&format!(
        "<link name=\"base\"/><link name=\"arm\"/>\n{}",
        GOOD_JOINT.replace("<axis", "<mimic joint=\"nope\"/><axis")
    ));
    let desc = parse(&text).unwrap();
    assert!(desc.joint("j1").unwrap().mimic.is_none());
    let lint = desc.lint();
    assert!(lint.iter().any(|w| w.contains("<string>:4") && w.contains("mimics 'nope'")), "{lint:?}");
    let text = robot(
        "<link name=\"base\"/><link name=\"a\"/><link name=\"b\"/>\n\
         <joint name=\"ja\" type=\"continuous\"><parent link=\"base\"/><child link=\"a\"/><mimic joint=\"jb\"/></joint>\n\
         <joint name=\"jb\" type=\"continuous\"><parent link=\"a\"/><child link=\"b\"/><mimic joint=\"ja\"/></joint>",
    );
    let e = parse(&text).unwrap_err();
    assert!(matches!(&e, RobotError::InvalidMimic { detail, .. } if detail.contains("cycle")), "{e}");
}

#[test]
fn unreadable_mesh_formats_load_and_are_reported() {
    let dir = tempfile::tempdir().unwrap();
    std::fs::write(dir.path().join("base.mesh"), "ogre binary").unwrap();
    let path = dir.path().join("r.urdf");
    let urdf = |file: &str| {
        robot(&format!(
            "<link name=\"base\"><collision><geometry><mesh filename=\"{file}\"/></geometry></collision></link>"
        ))
    };
    std::fs::write(&path, urdf("base.mesh")).unwrap();
    let desc = RobotDescription::from_urdf_file(&path, &MeshSearchPath::default()).unwrap();
    let lint = desc.lint();
    assert!(lint.iter().any(|w| w.contains("base.mesh") && w.contains("cannot read")), "{lint:?}");
    // COLLADA is read; a broken one is an error naming the file.
    std::fs::write(dir.path().join("base.dae"), "<COLLADA/>").unwrap();
    std::fs::write(&path, urdf("base.dae")).unwrap();
    let e = RobotDescription::from_urdf_file(&path, &MeshSearchPath::default()).unwrap_err();
    assert!(matches!(e, RobotError::InvalidMesh { .. }) && e.to_string().contains("base.dae"), "{e}");
}

#[test]
fn missing_mesh_lists_where_it_looked() {
    let dir = tempfile::tempdir().unwrap();
    let path = dir.path().join("r.urdf");
    let mut f = std::fs::File::create(&path).unwrap();
    write!(
        f,
        "{}",
        robot("<link name=\"base\"><collision><geometry><mesh filename=\"package://pkg/meshes/base.stl\"/></geometry></collision></link>")
    )
    .unwrap();
    let search = MeshSearchPath::new([dir.path().join("share")]);
    let e = RobotDescription::from_urdf_file(&path, &search).unwrap_err();
    match &e {
        RobotError::MeshNotFound { link, uri, searched, at } => {
            assert_eq!(link, "base");
            assert_eq!(uri, "package://pkg/meshes/base.stl");
            assert!(searched[0].ends_with("share/pkg/meshes/base.stl"));
            assert_eq!(at.line, Some(3));
            assert!(at.source.ends_with("r.urdf"));
        }
        other => panic!("unexpected {other}"),
    }
    // A corrupt mesh is an InvalidMesh error naming the file.
    std::fs::create_dir_all(dir.path().join("share/pkg/meshes")).unwrap();
    std::fs::write(dir.path().join("share/pkg/meshes/base.stl"), b"solid x\nfacet garbage").unwrap();
    let e = RobotDescription::from_urdf_file(&path, &search).unwrap_err();
    assert!(matches!(e, RobotError::InvalidMesh { .. }) && e.to_string().contains("base.stl"), "{e}");
}

#[test]
fn missing_file_is_an_io_error_naming_the_path() {
    let e = RobotDescription::from_urdf_file("/no/such/robot.urdf", &MeshSearchPath::default()).unwrap_err();
    assert!(matches!(e, RobotError::Io { .. }) && e.to_string().contains("/no/such/robot.urdf"), "{e}");
}

#[test]
fn unknown_frame_suggests_close_names() {
    let panda = RobotModel::panda();
    let e = panda.frame_id("panda_hnd").unwrap_err();
    assert!(e.to_string().contains("did you mean panda_hand"), "{e}");
}

#[test]
fn unknown_or_fixed_active_joints() {
    let desc = std::sync::Arc::new(RobotDescription::panda());
    let e = RobotModel::builder(desc.clone()).active_joints(["panda_joint9"]).build().unwrap_err();
    assert!(matches!(e, RobotError::UnknownJoint { .. }), "{e}");
    let e = RobotModel::builder(desc.clone()).active_joints(["panda_hand_joint"]).build().unwrap_err();
    assert!(matches!(e, RobotError::NotActuable { .. }), "{e}");
    let e = RobotModel::builder(desc.clone()).active_joints(["panda_finger_joint2"]).build().unwrap_err();
    assert!(e.to_string().contains("mimics 'panda_finger_joint1'"), "{e}");
    let e = RobotModel::builder(desc.clone()).chain("panda_hand", "panda_link3").build().unwrap_err();
    assert!(matches!(e, RobotError::NotAChain { .. }), "{e}");
    let e = RobotModel::builder(desc)
        .chain("panda_link0", "panda_hand")
        .hold("panda_finger_joint1", 0.5)
        .build()
        .unwrap_err();
    assert!(matches!(e, RobotError::HeldValueOutOfRange { .. }), "{e}");
}

#[test]
fn wrong_length_and_non_finite_configurations() {
    let panda = RobotModel::panda();
    let mut ws = KinematicsWorkspace::new(&panda);
    let e = panda.forward_kinematics(&mut ws, &[0.0; 6]).unwrap_err();
    assert!(matches!(e, RobotError::WrongDof { expected: 7, got: 6, .. }), "{e}");
    let mut q = panda.neutral_configuration();
    q[3] = f64::NAN;
    let e = panda.forward_kinematics(&mut ws, &q).unwrap_err();
    assert!(matches!(&e, RobotError::NonFinite { joint, index: 3, .. } if joint == "panda_joint4"), "{e}");
    q[3] = f64::INFINITY;
    assert!(matches!(panda.forward_kinematics(&mut ws, &q), Err(RobotError::NonFinite { .. })));
}

#[test]
fn structural_mistakes_name_their_line() {
    let cases = [
        (
            "<link name=\"a\"><collision><geometry><box size=\"1 2\"/></geometry></collision></link>",
            "must be 3 numbers",
        ),
        (
            "<link name=\"a\"/><link name=\"b\"/>\n<joint name=\"j\" type=\"revolute\"><parent link=\"a\"/><child link=\"b\"/><limit lower=\"x\" upper=\"1\" velocity=\"1\"/></joint>",
            "<limit lower=\"x\"> must be a number",
        ),
        (
            "<link name=\"a\"/><link name=\"b\"/>\n<joint name=\"j\" type=\"fixed\"><child link=\"b\"/></joint>",
            "no <parent link",
        ),
        (
            "<link name=\"a\"/><link name=\"b\"/>\n<joint name=\"j\" type=\"prismatic\"><parent link=\"a\"/><child link=\"b\"/></joint>",
            "has no <limit",
        ),
        ("<link/>", "has no name attribute"),
    ];
    for (body, message) in cases {
        let e = parse(&robot(body)).unwrap_err();
        assert!(matches!(e, RobotError::InvalidUrdf { .. }), "{e}");
        assert!(e.to_string().contains(message), "expected '{message}' in '{e}'");
        assert!(line_of(&e).is_some(), "no line in '{e}'");
    }
}

/// An ASCII STL of one tetrahedron (or of one flat triangle when `flat`).
fn stl(flat: bool) -> String {
    let tri = |a: [f64; 3], b: [f64; 3], c: [f64; 3]| {
        format!(
            "facet normal 0 0 0\nouter loop\nvertex {} {} {}\nvertex {} {} {}\nvertex {} {} {}\nendloop\nendfacet\n",
            a[0], a[1], a[2], b[0], b[1], b[2], c[0], c[1], c[2]
        )
    };
    let (o, x, y, z) = ([0.0; 3], [0.1, 0.0, 0.0], [0.0, 0.1, 0.0], [0.0, 0.0, 0.1]);
    let body = if flat { tri(o, x, y) } else { [tri(o, y, x), tri(o, x, z), tri(o, z, y), tri(x, y, z)].concat() };
    format!("solid t\n{body}endsolid t\n")
}

#[test]
fn a_zero_mesh_scale_is_refused_where_it_is_written() {
    let dir = tempfile::tempdir().unwrap();
    std::fs::write(dir.path().join("tet.stl"), stl(false)).unwrap();
    let path = dir.path().join("r.urdf");
    let urdf = |scale: &str| {
        robot(&format!(
            "<link name=\"base\">\n<collision><geometry><mesh filename=\"tet.stl\" scale=\"{scale}\"/></geometry></collision></link>"
        ))
    };
    // Passed `inspect`, then failed later as "cannot build a convex hull
    // from 4 points" naming neither link nor file.
    std::fs::write(&path, urdf("0 0 0")).unwrap();
    let e = RobotDescription::from_urdf_file(&path, &MeshSearchPath::default()).unwrap_err();
    assert!(matches!(e, RobotError::InvalidValue { field: "mesh scale x", .. }), "{e}");
    let text = e.to_string();
    assert!(text.contains("r.urdf:3") && text.contains("link 'base'") && text.contains("non-zero"), "{text}");
    // Mirroring (a negative factor) stays legal.
    std::fs::write(&path, urdf("-1 1 1")).unwrap();
    RobotDescription::from_urdf_file(&path, &MeshSearchPath::default()).unwrap();
}

#[test]
fn a_flat_collision_mesh_names_its_link_and_file() {
    let dir = tempfile::tempdir().unwrap();
    std::fs::write(dir.path().join("flat.stl"), stl(true)).unwrap();
    let path = dir.path().join("r.urdf");
    let text = robot(
        "<link name=\"base\"><collision><geometry><sphere radius=\"0.1\"/></geometry></collision>\n\
         <collision><geometry><mesh filename=\"flat.stl\"/></geometry></collision></link>",
    );
    std::fs::write(&path, text).unwrap();
    let desc = std::sync::Arc::new(RobotDescription::from_urdf_file(&path, &MeshSearchPath::default()).unwrap());
    let model = std::sync::Arc::new(RobotModel::builder(desc).build().unwrap());
    let e = tandem::collision::CollisionModel::builder(model).build().unwrap_err().to_string();
    assert!(e.contains("r.urdf") && e.contains("link 'base', collision element 1") && e.contains("flat.stl"), "{e}");
    assert!(e.contains("cannot build a convex hull from 3 points"), "{e}");
}
