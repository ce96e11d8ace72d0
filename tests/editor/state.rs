//! The editor's document core: undo/redo, refused connections, copy/paste, saving, autosave
//! and recovery, and saves that survive being killed.

use std::path::{Path, PathBuf};
use std::time::{Duration, Instant};

use tyndall::editor::{autosave_path, list_presets, preset_thumbnail, EditorState, UNDO_LIMIT};
use tyndall::graph::{load_file, save_string, ParamValue};

fn state() -> EditorState {
    EditorState::new(tyndall::nodes::registry().catalog().clone())
}

#[test]
fn undo_and_redo_restore_the_exact_document_over_many_steps() {
    let mut s = state();
    let mut history = vec![save_string(s.graph())];
    let c = s.add_node("Constant", [0.0, 0.0]).expect("add");
    history.push(save_string(s.graph()));
    let m = s.add_node("Math", [200.0, 0.0]).expect("add");
    history.push(save_string(s.graph()));
    s.connect(&format!("{c}.value"), &format!("{m}.a"))
        .expect("connect");
    history.push(save_string(s.graph()));
    for i in 0..120 {
        s.set_param(&m, "b", ParamValue::Float(i as f64 * 0.5))
            .expect("param");
        history.push(save_string(s.graph()));
    }
    assert_eq!(s.undo_depth(), 123);
    // Undo walks back through every state exactly.
    for want in history.iter().rev().skip(1) {
        assert!(s.undo());
        assert_eq!(&save_string(s.graph()), want);
    }
    assert!(!s.undo(), "nothing left to undo");
    for want in history.iter().skip(1) {
        assert!(s.redo());
        assert_eq!(&save_string(s.graph()), want);
    }
    // History is bounded.
    for i in 0..(UNDO_LIMIT + 20) {
        s.set_param(&m, "a", ParamValue::Float(i as f64))
            .expect("param");
    }
    assert_eq!(s.undo_depth(), UNDO_LIMIT);
}

#[test]
fn refused_connections_say_why_and_change_nothing() {
    let mut s = state();
    let input = s.add_node("ImageInput", [0.0, 0.0]).expect("add");
    let m1 = s.add_node("Math", [0.0, 0.0]).expect("add");
    let m2 = s.add_node("Math", [0.0, 0.0]).expect("add");
    s.connect(&format!("{m1}.out"), &format!("{m2}.a"))
        .expect("ok");
    let before = save_string(s.graph());
    let depth = s.undo_depth();
    let err = s
        .connect(&format!("{input}.shadow"), &format!("{m1}.a"))
        .expect_err("type mismatch");
    assert!(err.to_string().contains("port type mismatch"), "{err}");
    let err = s
        .connect(&format!("{m2}.out"), &format!("{m1}.b"))
        .expect_err("cycle");
    assert!(err.to_string().contains("cycle"), "{err}");
    assert_eq!(save_string(s.graph()), before);
    assert_eq!(s.undo_depth(), depth);
}

#[test]
fn copy_paste_between_graphs_and_duplicate() {
    let mut a = state();
    let c = a.add_node("Constant", [10.0, 10.0]).expect("add");
    let m = a.add_node("Math", [100.0, 10.0]).expect("add");
    let r = a.add_node("Remap", [200.0, 10.0]).expect("add");
    a.connect(&format!("{c}.value"), &format!("{m}.a"))
        .expect("edge");
    a.connect(&format!("{m}.out"), &format!("{r}.in"))
        .expect("edge");
    a.set_param(&m, "op", ParamValue::Enum("mul".into()))
        .expect("param");
    let clip = a.copy(&[c.clone(), m.clone()]);
    let mut b = state();
    let existing = b.add_node("Constant", [0.0, 0.0]).expect("add");
    let new = b.paste(&clip, [5.0, 5.0]).expect("paste");
    assert_eq!(new.len(), 2);
    assert!(!new.contains(&existing), "pasted nodes get fresh ids");
    let edges = b.graph().edges();
    assert_eq!(
        edges.len(),
        1,
        "the edge between the copied nodes comes along, the one to Remap does not"
    );
    let pasted_math = new
        .iter()
        .find(|id| b.graph().node(id).is_some_and(|n| n.kind == "Math"))
        .expect("math");
    assert_eq!(
        b.graph().node(pasted_math).and_then(|n| n.params.get("op")),
        Some(&ParamValue::Enum("mul".into()))
    );
    assert_eq!(
        b.graph().node(pasted_math).and_then(|n| n.pos),
        Some([105.0, 15.0])
    );
    // One paste is one undo step.
    assert!(b.undo());
    assert_eq!(b.graph().len(), 1);
    let dup = a.duplicate(&[m.clone(), r.clone()]).expect("duplicate");
    assert_eq!(a.graph().len(), 5);
    assert_eq!(dup.len(), 2);
}

#[test]
fn save_reopen_dirty_and_autosave_recovery() {
    let dir = tempfile::tempdir().expect("tempdir");
    let path = dir.path().join("g.ron");
    let mut s = state();
    assert!(s.save().is_err(), "untitled: save needs save as");
    let c = s.add_node("Constant", [1.0, 2.0]).expect("add");
    assert!(s.is_dirty());
    s.save_as(&path).expect("save");
    assert!(!s.is_dirty());
    let reopened = EditorState::open(s.catalog().clone(), &path).expect("open");
    assert_eq!(save_string(reopened.graph()), save_string(s.graph()));
    // Autosave writes a side file only when there are unsaved changes and the period passed.
    s.set_autosave_period(Duration::ZERO);
    assert!(
        !s.tick_autosave(Instant::now()).expect("tick"),
        "nothing to autosave"
    );
    s.set_param(&c, "value", ParamValue::Float(4.0))
        .expect("param");
    assert!(s.tick_autosave(Instant::now()).expect("tick"));
    let side = autosave_path(&path);
    assert!(side.exists());
    // A crash now: the next start finds the autosave, newer than the file, and recovers it.
    std::thread::sleep(Duration::from_millis(20));
    let found = EditorState::recoverable(&path).expect("offer recovery");
    let mut next = EditorState::open(s.catalog().clone(), &path).expect("open");
    next.recover(&found).expect("recover");
    assert_eq!(save_string(next.graph()), save_string(s.graph()));
    assert!(next.is_dirty(), "recovered changes are not saved yet");
    next.save().expect("save");
    assert!(!side.exists(), "saving removes the autosave");
    assert!(EditorState::recoverable(&path).is_none());
}

#[test]
fn preset_library_lists_and_merges() {
    let root = Path::new(env!("CARGO_MANIFEST_DIR")).join("graphs");
    let presets = list_presets(&[root]);
    assert!(
        presets.iter().any(|p| p.name == "physical/window"),
        "{presets:?}"
    );
    assert!(presets
        .iter()
        .any(|p| p.name == "stylize/tree_hole_filling"));
    // Library groups and the benchmarks' inputs are not looks to open.
    assert!(
        !presets
            .iter()
            .any(|p| p.name.starts_with("lib/") || p.name.starts_with("bench/")),
        "{presets:?}"
    );
    let mut s = state();
    let text = std::fs::read_to_string(&presets[0].path).expect("read");
    let merged = s.paste(&text, [0.0, 0.0]).expect("merge");
    assert_eq!(merged.len(), s.graph().len());
    let dir = tempfile::tempdir().expect("tempdir");
    let out = dir.path().join("sel.ron");
    s.save_preset(&merged[..2], &out).expect("save preset");
    assert_eq!(load_file(&out, s.catalog()).expect("load").len(), 2);
}

/// Child side of the kill test: save alternating documents to `TYNDALL_SAVE_LOOP` forever.
#[test]
fn save_loop_child() {
    let Ok(target) = std::env::var("TYNDALL_SAVE_LOOP") else {
        return;
    };
    let mut s = state();
    let m = s.add_node("Math", [0.0, 0.0]).expect("add");
    for i in 0..400 {
        s.add_node("Constant", [i as f32, 0.0]).expect("add"); // a file of a few tens of kB
    }
    let mut i = 0u64;
    loop {
        s.set_param(&m, "a", ParamValue::Float(i as f64))
            .expect("param");
        s.save_as(Path::new(&target)).expect("save");
        i += 1;
    }
}

/// Killing the process in the middle of saves never leaves a truncated or missing file.
#[test]
fn killing_during_save_leaves_a_whole_file() {
    let dir = tempfile::tempdir().expect("tempdir");
    let target = dir.path().join("killed.ron");
    let exe = std::env::current_exe().expect("test binary");
    // The child test's name as the harness knows it: its module path below the binary's root
    // (`state::save_loop_child` in tests/editor/).
    let child_test = match module_path!().split_once("::") {
        Some((_, module)) => format!("{module}::save_loop_child"),
        None => "save_loop_child".to_string(),
    };
    let catalog = tyndall::nodes::registry().catalog().clone();
    for round in 0..12 {
        let mut child = std::process::Command::new(&exe)
            .args([
                "--exact",
                child_test.as_str(),
                "--nocapture",
                "--test-threads",
                "1",
            ])
            .env("TYNDALL_SAVE_LOOP", &target)
            .stdout(std::process::Stdio::null())
            .stderr(std::process::Stdio::null())
            .spawn()
            .expect("spawn");
        // Let it get going (the first save creates the file), then kill it at a varying moment.
        let wait = Instant::now();
        while !target.exists() && wait.elapsed() < Duration::from_secs(20) {
            std::thread::sleep(Duration::from_millis(5));
        }
        std::thread::sleep(Duration::from_millis(7 + 13 * round));
        child.kill().expect("kill");
        let _ = child.wait();
        let g = load_file(&target, &catalog).unwrap_or_else(|e| panic!("round {round}: {e}"));
        assert_eq!(g.len(), 401, "round {round}");
    }
}

/// The preset browser's pictures: beside the preset, under `docs/` for the library in `graphs/`,
/// or an animated preset's first rendered frame; every library preset has one (the bench graphs
/// are measuring set-ups, not looks).
#[test]
fn preset_thumbnails_beside_under_docs_or_first_frame() {
    // Paths as the editor lists them when started in a checkout (tests run in the crate root).
    assert_eq!(
        preset_thumbnail(Path::new("graphs/physical/tree.ron")),
        Some(PathBuf::from("docs/physical/tree.png"))
    );
    assert_eq!(
        preset_thumbnail(Path::new("graphs/stylize/tree_holes_animated.ron")),
        Some(PathBuf::from("docs/stylize/tree_holes_animated_0000.png"))
    );
    let missing: Vec<String> = list_presets(&[PathBuf::from("graphs")])
        .into_iter()
        .filter(|p| preset_thumbnail(&p.path).is_none())
        .map(|p| p.name)
        .collect();
    assert!(missing.is_empty(), "presets without a picture: {missing:?}");
    // A user folder: the picture beside it, a sequence's first frame, nothing that merely
    // starts with the name.
    let dir = tempfile::tempdir().expect("tempdir");
    let touch = |name: &str| std::fs::write(dir.path().join(name), b"").expect("write");
    for name in [
        "a.ron",
        "a.png",
        "b.ron",
        "b.0002.png",
        "b.0001.png",
        "c.ron",
        "c_x.png",
    ] {
        touch(name);
    }
    touch("c2.png");
    touch("c_.png");
    let at = |name: &str| preset_thumbnail(&dir.path().join(name));
    assert_eq!(at("a.ron"), Some(dir.path().join("a.png")));
    assert_eq!(at("b.ron"), Some(dir.path().join("b.0001.png")));
    assert_eq!(at("c.ron"), None);
}

/// Editing inside groups: entering nested groups, a change there rewritten into every
/// definition up the path (library groups become embedded copies, other uses of the library
/// group keep following it), a change that breaks a port refused, undo across scopes.
#[test]
fn edits_inside_nested_groups_and_undo_across_scopes() {
    let cat = tyndall::nodes::registry().catalog().clone();
    let path = Path::new(env!("CARGO_MANIFEST_DIR")).join("graphs/stylize/tree_hole_filling.ron");
    let mut s = EditorState::open(cat.clone(), &path).expect("open");
    let original = save_string(s.root());
    assert!(
        s.enter("scene").is_err(),
        "a built-in node cannot be entered"
    );
    s.enter("holes").expect("enter HoleFilling");
    assert!(s.graph().node("close").is_some());
    s.enter("shafts").expect("enter the Shafts inside it");
    assert_eq!(s.scope(), ["holes".to_string(), "shafts".to_string()]);
    assert_eq!(s.full_id("scatter"), "holes/shafts/scatter");
    assert_eq!(
        s.driving_knob("scatter", "sigma_t").as_deref(),
        Some("sigma_t")
    );
    assert_eq!(s.driving_knob("scatter", "steps"), None);
    s.set_param("scatter", "steps", ParamValue::Int(40))
        .expect("inner edit");
    // Rewritten up the path: HoleFilling and its Shafts are embedded copies now; the
    // document's own Shafts instance still follows the library file.
    let root = s.root();
    let holes = &root.groups()["HoleFilling"];
    assert!(holes.library.is_none());
    assert!(holes.graph.groups()["Shafts"].library.is_none());
    assert!(root.groups()["Shafts"].library.is_some());
    let flat = root.flatten(&cat).expect("flatten");
    let steps = |id: &str| flat.param_at(&cat, id, "steps", 0.0).expect("steps");
    assert_eq!(steps("holes/shafts/scatter"), ParamValue::Int(40));
    assert_ne!(steps("physical/scatter"), ParamValue::Int(40));
    // Deleting the inner node a port feeds is refused, naming the group; nothing changes.
    let text = save_string(s.root());
    let err = s.delete(&["scatter".into()]).expect_err("port target");
    assert!(err.to_string().contains("Shafts"), "{err}");
    assert_eq!(save_string(s.root()), text);
    // Expose from inside: a knob on the enclosing group, named after the parameter.
    assert_eq!(s.expose_here("scatter", "steps").expect("expose"), "steps");
    assert!(s
        .enclosing()
        .expect("inside")
        .knobs
        .iter()
        .any(|k| k.name == "steps"));
    // Undo goes back through both edits whatever the scope.
    s.leave_to(0);
    assert!(s.undo() && s.undo());
    assert_eq!(save_string(s.root()), original);
    // Undoing the grouping while inside the group leaves it for the document.
    let g = s.group(&["scene".into(), "shadow".into()]).expect("group");
    s.enter(&g).expect("enter");
    assert!(s.undo());
    assert!(s.scope().is_empty());
    assert_eq!(save_string(s.root()), original);
}

/// Pasting a group whose name the document uses for a different definition brings it in
/// renamed, so the document's own instances keep their definition.
#[test]
fn pasting_a_changed_group_renames_it() {
    let cat = tyndall::nodes::registry().catalog().clone();
    let path = Path::new(env!("CARGO_MANIFEST_DIR")).join("graphs/stylize/tree_hole_filling.ron");
    let mut s = EditorState::open(cat, &path).expect("open");
    let clip = s.copy(&["holes".into()]);
    s.expose("holes", "close", "method", "method")
        .expect("expose");
    let mine = s.root().groups()["HoleFilling"].clone();
    let ids = s.paste(&clip, [40.0, 40.0]).expect("paste");
    let pasted = s.root().node(&ids[0]).expect("pasted").kind.clone();
    assert_eq!(pasted, "HoleFilling2");
    assert_eq!(*s.root().groups()["HoleFilling"], *mine);
    assert_ne!(*s.root().groups()["HoleFilling2"], *mine);
    // The same definition pasted again is shared, not renamed.
    let again = s.copy(&["holes".into()]);
    let ids = s.paste(&again, [80.0, 80.0]).expect("paste");
    assert_eq!(s.root().node(&ids[0]).expect("pasted").kind, "HoleFilling");
}
