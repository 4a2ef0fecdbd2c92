//! Robots far larger than an arm, as URDF text: long chains (optionally
//! every joint mimicking the one before) and a humanoid-like tree. Shared
//! by `tests/large_robots.rs` and the `collision` bench.
#![allow(dead_code)]

use std::fmt::Write;

/// A chain of `links` links, each 0.1 m along z from its parent through a
/// revolute joint about y, with a 3 cm sphere at its origin; joint k mimics
/// joint k − 1 when `mimics` (a mimic chain as long as the robot).
pub fn chain_urdf(links: usize, mimics: bool) -> String {
    let mut s = String::from("<robot name=\"chain\">\n");
    for k in 0..links {
        let _ = writeln!(
            s,
            "<link name=\"l{k}\"><collision><geometry><sphere radius=\"0.03\"/></geometry></collision></link>"
        );
        if k > 0 {
            let mimic = if mimics && k > 1 { format!("<mimic joint=\"j{}\"/>", k - 1) } else { String::new() };
            let _ = writeln!(
                s,
                "<joint name=\"j{k}\" type=\"revolute\"><parent link=\"l{}\"/><child link=\"l{k}\"/>\
                 <origin xyz=\"0 0 0.1\"/><axis xyz=\"0 1 0\"/><limit lower=\"-3\" upper=\"3\" effort=\"1\" velocity=\"1\"/>{mimic}</joint>",
                k - 1
            );
        }
    }
    s.push_str("</robot>\n");
    s
}

/// A humanoid-like tree: a 3-link torso with a 2-link head, two 7-link
/// arms with five 3-link fingers each, two 6-link legs; four spheres per link.
pub fn humanoid_urdf() -> String {
    let mut s = String::from("<robot name=\"humanoid\">\n");
    let link = |s: &mut String, name: &str| {
        let spheres: String = (0..4)
            .map(|i| {
                format!(
                    "<collision><origin xyz=\"0 0 {}\"/><geometry><sphere radius=\"0.02\"/></geometry></collision>",
                    0.02 * i as f64
                )
            })
            .collect();
        let _ = writeln!(s, "<link name=\"{name}\">{spheres}</link>");
    };
    let joint = |s: &mut String, parent: &str, child: &str, xyz: [f64; 3], axis: &str| {
        let _ = writeln!(
            s,
            "<joint name=\"{child}_joint\" type=\"revolute\"><parent link=\"{parent}\"/><child link=\"{child}\"/>\
             <origin xyz=\"{} {} {}\"/><axis xyz=\"{axis}\"/><limit lower=\"-2\" upper=\"2\" effort=\"1\" velocity=\"1\"/></joint>",
            xyz[0], xyz[1], xyz[2]
        );
    };
    link(&mut s, "pelvis");
    let chain = |s: &mut String, parent: &str, prefix: &str, count: usize, offset: [f64; 3]| -> String {
        let mut at = parent.to_string();
        for k in 0..count {
            let name = format!("{prefix}{k}");
            link(s, &name);
            let axis = ["1 0 0", "0 1 0", "0 0 1"][k % 3];
            joint(s, &at, &name, if k == 0 { offset } else { [0.0, 0.0, 0.1] }, axis);
            at = name;
        }
        at
    };
    let neck = chain(&mut s, "pelvis", "torso", 3, [0.0, 0.0, 0.1]);
    chain(&mut s, &neck, "head", 2, [0.0, 0.0, 0.15]);
    for side in ["l", "r"] {
        let y = if side == "l" { 0.2 } else { -0.2 };
        let wrist = chain(&mut s, &neck, &format!("{side}_arm"), 7, [0.0, y, 0.0]);
        for f in 0..5 {
            chain(&mut s, &wrist, &format!("{side}_finger{f}_"), 3, [0.02 * f as f64, 0.0, 0.05]);
        }
        chain(&mut s, "pelvis", &format!("{side}_leg"), 6, [0.0, y / 2.0, -0.1]);
    }
    s.push_str("</robot>\n");
    s
}
