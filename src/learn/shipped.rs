//! The robot policy tandem ships for `problems/panda_grasp_family.toml`:
//! trained once on a large `tandem generate` dataset, embedded in the
//! library, its provenance (command, data and training seeds, commit,
//! measured success) beside it in `policies/`. `tandem experiment policy`
//! evaluates it unless given `--policy FILE` or `--train`.

use super::{LearnError, PolicyNetwork};
use std::path::Path;

/// The shipped policy's file in the repository (names it in messages).
pub const SHIPPED_POLICY_PATH: &str = "policies/panda_grasp_family.safetensors";

/// Its provenance (JSON): how it was made and what it measured.
pub const SHIPPED_POLICY_PROVENANCE: &str = include_str!("../../policies/panda_grasp_family.json");

const SHIPPED_POLICY: &[u8] = include_bytes!("../../policies/panda_grasp_family.safetensors");

/// The shipped policy network (its metadata names the family it was
/// trained for, `panda_grasp_family`).
///
/// # Errors
/// None for the embedded file (its checks run as for any policy file).
pub fn shipped_policy() -> Result<PolicyNetwork, LearnError> {
    PolicyNetwork::from_bytes(SHIPPED_POLICY, Path::new(SHIPPED_POLICY_PATH))
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn the_shipped_policy_loads_and_states_its_provenance() {
        let network = shipped_policy().unwrap();
        let meta = network.meta();
        assert_eq!(meta.family, "panda_grasp_family");
        assert_eq!(meta.joints.len(), 7);
        let provenance: serde_json::Value = serde_json::from_str(SHIPPED_POLICY_PROVENANCE).unwrap();
        for key in ["command", "data", "training", "commit", "evaluation"] {
            assert!(provenance.get(key).is_some(), "provenance lacks {key}");
        }
        assert_eq!(provenance["training"]["trajectories"].as_u64(), Some(meta.trajectories as u64));
    }
}
