//! Running DDS peers safely: a private network namespace with only loopback up, and
//! whether this machine can make one and has the Python peer's packages.

use std::process::{Command, Output};

use tether_testkit::{or_skip, python_modules, skip_unless};

/// Whether `program ARGS` runs and succeeds.
pub fn runs(program: &str, args: &[&str]) -> bool {
    Command::new(program)
        .args(args)
        .output()
        .is_ok_and(|o| o.status.success())
}

/// Whether this machine can run the Python peers: a private network namespace and the
/// Python packages.
pub fn peer_available() -> bool {
    skip_unless(
        runs("unshare", &["-n", "true"]),
        "cannot make a private network namespace (`unshare -n` needs root)",
    ) && or_skip(python_modules(
        &["cyclonedds", "rosbags"],
        "cyclonedds rosbags",
    ))
    .is_some()
}

/// Runs `sh -c SCRIPT` in a fresh network namespace once its loopback is up (with
/// multicast): the interface must be up before any participant starts, or DDS finds no
/// address to announce and the participant is invisible for the whole run. Nothing in
/// the namespace reaches a real interface.
pub fn in_private_network(script: &str) -> Output {
    Command::new("unshare")
        .args([
            "-n",
            "sh",
            "-c",
            &format!("ip link set lo up && ip link set lo multicast on || exit 97\n{script}"),
        ])
        .output()
        .expect("unshare runs")
}
