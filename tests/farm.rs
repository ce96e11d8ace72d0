//! Farms for real: `tyndall job`'s Open Job Description template run by OpenJD's own CLI
//! (issue #62). A binary of its own so CI's GL pass can leave it out: it drives the `tyndall`
//! binary through `openjd`, whose backend the Vulkan pass has already covered.

#[macro_use]
#[path = "common/mod.rs"]
mod common;

/// `tyndall job` through Open Job Description's own CLI (issue #62): scripts/test_openjd.sh
/// installs PyPI's openjd-cli into target/openjd-venv, checks the template, kills a task after
/// its first frame, runs the whole step and finds every frame exactly once.
#[test]
fn an_openjd_job_renders_every_frame_once_and_resumes_a_killed_task() {
    if common::gpu().is_none() {
        return;
    }
    let text = common::run_script("scripts/test_openjd.sh");
    assert!(
        text.contains("openjd: 20 frames in 3 tasks, each written once"),
        "{text}"
    );
}
