//! The Python package (`python/`): `scripts/test_python.sh` builds it into a virtualenv and runs
//! its pytest suite and the examples' graph-evaluation tests. This test fails when the script
//! does — a build error, a failed Python test, or pytest collecting no tests (its exit code 5).

mod common;

#[test]
fn the_python_package_builds_and_its_pytest_suite_passes() {
    if common::gpu().is_none() {
        return;
    }
    let text = common::run_script("scripts/test_python.sh");
    // The summary line, e.g. "22 passed in 6.1s": tests were collected and passed.
    assert!(
        text.lines()
            .any(|l| l.contains(" passed") && !l.contains("failed")),
        "{text}"
    );
    eprintln!("{text}");
}
