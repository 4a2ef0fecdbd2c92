//! SRDF text → groups, states, disabled pairs; checked against the
//! embedded Panda, each group turned into a joint selection and a model.
#![no_main]

use libfuzzer_sys::fuzz_target;
use std::sync::{Arc, LazyLock};
use tandem::robot::{RobotDescription, RobotModel, Srdf};

static PANDA: LazyLock<Arc<RobotDescription>> = LazyLock::new(|| Arc::new(RobotDescription::panda()));

fuzz_target!(|data: &[u8]| {
    let Ok(text) = std::str::from_utf8(data) else { return };
    let Ok(srdf) = Srdf::from_srdf_str(text) else { return };
    if srdf.check_against(&PANDA).is_err() {
        return;
    }
    for group in &srdf.groups {
        if let Ok(selection) = srdf.joint_selection(&group.name) {
            let _ = RobotModel::builder(PANDA.clone()).selection(selection).build();
        }
    }
});
