"""The package's own tests: documents, evaluation, errors, one node on arrays, rendering."""

import os
import signal
import threading
import time

import numpy as np
import pytest

import tyndall

WINDOW = "graphs/physical/window.ron"
SMALL = (96, 54)


@pytest.fixture(autouse=True)
def _in_root(root, monkeypatch):
    monkeypatch.chdir(root)


@pytest.fixture(scope="module")
def ev():
    return tyndall.Evaluator()


def test_catalog_lists_kinds_and_library_groups():
    cat = tyndall.catalog()
    kinds = {c["kind"]: c for c in cat}
    s = kinds["SingleScattering"]
    assert s["library"] is None
    steps = next(p for p in s["params"] if p["name"] == "steps")
    assert steps["type"] == "Int" and steps["min"] is not None and steps["doc"]
    method = next(p for p in s["params"] if p["name"] == "method")
    assert "MinMax" in method["choices"]
    assert any(o["name"] == "inscatter" for o in s["outputs"])
    # Library groups (graphs/lib, found from the working directory) with their knobs.
    hf = kinds["HoleFilling"]
    assert hf["library"] == "stylize/hole_filling"
    assert {p["name"] for p in hf["params"]} >= {"radius", "exposure"}


def test_load_save_and_text_round_trip(tmp_path):
    g = tyndall.Graph.load(WINDOW)
    assert g.nodes["scatter"] == "SingleScattering"
    assert ("shadow.map", "scatter.shadow") in g.edges
    out = tmp_path / "w.ron"
    g.save(out)
    again = tyndall.Graph.load(out)
    assert again.to_str() == g.to_str()
    assert tyndall.Graph.from_str(g.to_str()).to_str() == g.to_str()


def test_parameters_nodes_edges_and_keys():
    g = tyndall.Graph.load(WINDOW)
    assert g.get("tonemap", "exposure") == 0.5
    assert g.get("scatter", "method") == "MinMax"
    g.set("tonemap", "exposure", 1)  # an int where a float goes is fine
    assert g.get("tonemap", "exposure") == 1.0
    g.set_keys("tonemap", "exposure", [(0, 0.0), (10, 2.0, "linear")])
    assert g.keys("tonemap", "exposure") == [(0.0, 0.0, "linear"), (10.0, 2.0, "linear")]
    assert g.get("tonemap", "exposure", time=5) == pytest.approx(1.0)
    m = g.add_node("", "Math", op="mul", b=2.0)
    assert g.nodes[m] == "Math" and g.get(m, "op") == "mul"
    g.connect("scatter.inscatter", f"{m}.a")
    assert ("scatter.inscatter", f"{m}.a") in g.edges
    assert g.disconnect(f"{m}.a")
    g.remove_node(m)
    assert m not in g.nodes


def test_errors_carry_node_port_and_param():
    g = tyndall.Graph.load(WINDOW)
    with pytest.raises(tyndall.GraphError) as e:
        g.set("tonemap", "exposure", 100.0)
    assert isinstance(e.value, ValueError)
    assert (e.value.node, e.value.param, e.value.port) == ("tonemap", "exposure", None)
    assert "range" in str(e.value)
    with pytest.raises(tyndall.GraphError) as e:
        g.set("scatter", "method", "Fast")
    assert (e.value.node, e.value.param) == ("scatter", "method")
    with pytest.raises(tyndall.GraphError) as e:
        g.add_node("odd", "NoSuchKind")
    assert e.value.node == "odd" and "NoSuchKind" in str(e.value)
    # A depth (Depth) cannot feed a scene input (Scene).
    with pytest.raises(tyndall.GraphError) as e:
        g.connect("gbuffer.depth", "shadow.scene")
    assert (e.value.node, e.value.port) == ("shadow", "scene")
    with pytest.raises(tyndall.GraphError) as e:
        tyndall.Graph.from_str("(version: 3, nodes: {")
    assert e.value.node is None


def test_an_evaluation_error_names_the_node(ev, tmp_path):
    g = tyndall.Graph()
    g.add_node("plate", "ImageInput", path=str(tmp_path / "missing.exr"))
    with pytest.raises(tyndall.EvalError) as e:
        ev.eval(g, ["plate.image"], size=SMALL)
    assert isinstance(e.value, RuntimeError)
    assert e.value.node == "plate"
    assert "missing.exr" in str(e.value)


def test_reevaluation_runs_only_the_changed_node_and_below(ev):
    g = tyndall.Graph.load(WINDOW)
    first = ev.eval(g, ["tonemap.out"], size=SMALL)
    assert "scatter" in first.stats.ran
    img = first["tonemap.out"]
    assert img.shape == (SMALL[1], SMALL[0], 4) and img.dtype == np.float32
    g.set("tonemap", "exposure", 1.5)
    second = ev.eval(g, ["tonemap.out"], size=SMALL)
    assert second.stats.ran == ["tonemap"]
    assert set(second.stats.reused) == {"scene", "shadow", "gbuffer", "scatter", "composite"}
    assert not np.array_equal(img, second["tonemap.out"])
    g.set("scatter", "steps", 48)
    third = ev.eval(g, ["tonemap.out"], size=SMALL)
    assert sorted(third.stats.ran) == ["composite", "scatter", "tonemap"]


def test_outputs_default_to_what_the_graph_writes_and_carry_cameras(ev):
    g = tyndall.Graph.load(WINDOW)
    out = ev.eval(g, size=SMALL)
    assert list(out) == ["tonemap.out"]
    depth = ev.eval(g, ["gbuffer.depth"], size=SMALL)
    assert depth["gbuffer.depth"].shape == (SMALL[1], SMALL[0])
    cam = depth.cameras["gbuffer.depth"]
    assert len(cam["view"]) == 4 and cam["far"] > 0


def test_groups_are_reached_inside(ev):
    g = tyndall.Graph.load("graphs/stylize/tree_hole_filling.ron")
    g.set("holes", "radius", 10.0)  # an exposed knob
    g.set("shadow", "resolution", 256)
    out = ev.eval(g, ["holes/close.map", "holes.image"], size=SMALL)
    assert out["holes/close.map"].ndim == 2
    assert "holes/close" in out.stats.ran


def test_eval_equals_the_cli_exr_exactly(ev, cli, tmp_path):
    exr = tmp_path / "cli.exr"
    r = cli("eval", WINDOW, "--output", f"tonemap.out={exr}", "--size", "96x54")
    assert r.returncode == 0, r.stderr
    mine = ev.eval(tyndall.Graph.load(WINDOW), ["tonemap.out"], size=SMALL)["tonemap.out"]
    theirs = tyndall.read_image(exr)
    assert theirs.shape == mine.shape
    assert np.array_equal(theirs, mine)


def test_one_node_on_arrays():
    a = np.linspace(0, 1, 20, dtype=np.float32).reshape(4, 5)
    b = np.full((4, 5), 0.25)
    out = tyndall.node("Math", {"op": "add"}, {"a": a, "b": b})
    assert list(out) == ["out"]
    assert np.array_equal(out["out"], a + np.float32(0.25))
    # The former "kind.port" keys still read, with a DeprecationWarning naming the new key.
    with pytest.warns(DeprecationWarning, match=r'use \["out"\]'):
        assert np.array_equal(out["math.out"], out["out"])
    with pytest.warns(DeprecationWarning):
        assert "math.out" in out
    with pytest.warns(DeprecationWarning):
        assert out.get("math.out") is not None
    assert "math.nope" not in out and out.get("tonemap.out") is None
    with pytest.raises(KeyError):
        out["nope"]
    rgb = np.full((3, 2, 3), 0.5)
    img = tyndall.node("Tonemap", {"exposure": 0.0}, {"image": rgb})["out"]
    assert img.shape == (3, 2, 4)
    with pytest.raises(tyndall.GraphError) as e:
        tyndall.node("Math", inputs={"c": a})
    assert (e.value.node, e.value.port) == ("math", "c")
    with pytest.raises(tyndall.GraphError) as e:
        tyndall.node("Math", {"op": "nope"})
    assert e.value.param == "op"


def test_render_frames_with_progress(tmp_path):
    g = tyndall.Graph.from_str(
        """(version: 3, nodes: {
            "c": (kind: "Constant", params: {"value": 0.5}),
            "out": (kind: "ImageOutput", params: {"path": "c_####.exr"}),
        }, edges: [("c.value", "out.image")])"""
    )
    seen = []
    done = tyndall.render(g, "1-3", output_dir=tmp_path, size=(8, 4),
                          progress=lambda f, i, n: seen.append((f, i, n)))
    assert done == [1, 2, 3]
    assert seen == [(1, 1, 3), (2, 2, 3), (3, 3, 3)]
    for f in (1, 2, 3):
        assert (tmp_path / f"c_{f:04d}.exr").is_file()


def test_render_writes_in_the_background_the_same_bytes_as_alone(tmp_path):
    # Frames are written on background threads while the next one evaluates: a sequence's files
    # are the bytes of the same frames rendered one call each, and all exist when render returns.
    g = tyndall.Graph.load(WINDOW)
    g.set("scatter", "steps", 8)
    seq, alone = tmp_path / "seq", tmp_path / "alone"
    assert tyndall.render(g, "1-4", output_dir=seq, size=(64, 36)) == [1, 2, 3, 4]
    for f in (1, 2, 3, 4):
        tyndall.render(g, str(f), output_dir=alone, size=(64, 36))
    names = sorted(p.name for p in seq.rglob("*") if p.is_file())
    assert names and names == sorted(p.name for p in alone.rglob("*") if p.is_file())
    for p in seq.rglob("*"):
        if p.is_file():
            assert p.read_bytes() == (alone / p.relative_to(seq)).read_bytes(), p


def test_render_raises_for_a_file_it_could_not_write(tmp_path):
    g = tyndall.Graph.from_str(
        """(version: 3, nodes: {
            "c": (kind: "Constant", params: {"value": 0.5}),
            "out": (kind: "ImageOutput", params: {"path": "c_####.exr"}),
        }, edges: [("c.value", "out.image")])"""
    )
    blocked = tmp_path / "c_0002.exr"
    blocked.mkdir()  # a folder where frame 2's file should go
    with pytest.raises(OSError, match="c_0002.exr"):
        tyndall.render(g, "1-3", output_dir=tmp_path, size=(8, 4))
    assert (tmp_path / "c_0001.exr").is_file() and (tmp_path / "c_0003.exr").is_file()


def test_gpu_work_releases_the_gil_and_ctrl_c_interrupts(ev):
    g = tyndall.Graph.load(WINDOW)
    g.set("scatter", "steps", 256)
    ticks = []
    stop = threading.Event()

    def count():
        while not stop.is_set():
            ticks.append(1)
            time.sleep(0.001)

    t = threading.Thread(target=count)
    t.start()
    try:
        ev.eval(g, ["tonemap.out"], size=(320, 180))
    finally:
        stop.set()
        t.join()
    assert len(ticks) > 10, "another Python thread ran during the evaluation"
    # Ctrl+C during a long evaluation: KeyboardInterrupt at once; the evaluator still works.
    # The evaluation is ~7x the signal's delay here (1.4 s unloaded at 2048 steps, 1080p), so a
    # loaded machine does not finish it before the signal lands (512 steps at 540p, 0.6 s,
    # did once).
    g.set("scatter", "steps", 2048)
    # Python maps SIGINT to KeyboardInterrupt only if its parent did not ignore the signal,
    # and a shell ignores it for background jobs (`cargo test &`): install the handler.
    previous = signal.signal(signal.SIGINT, signal.default_int_handler)
    timer = threading.Timer(0.2, lambda: os.kill(os.getpid(), signal.SIGINT))
    start = time.monotonic()
    timer.start()
    with pytest.raises(KeyboardInterrupt):
        try:
            ev.eval(g, ["tonemap.out"], size=(1920, 1080))
        finally:
            signal.signal(signal.SIGINT, previous)
    assert time.monotonic() - start < 5.0
    out = ev.eval(g, ["tonemap.out"], size=SMALL)
    assert out["tonemap.out"].shape == (SMALL[1], SMALL[0], 4)
