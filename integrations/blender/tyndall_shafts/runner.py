"""The parts of the add-on that do not need Blender: finding the `tyndall` binary and the
preset graphs, asking a graph which nodes to set, building the `tyndall render` command, and
reading its progress. Each failure is a `TyndallError` whose message says what is wrong."""

import json
import os
import shutil
import subprocess
import threading
import queue


class TyndallError(Exception):
    """A problem the artist can fix, worded for a Blender report."""


def find_binary(configured):
    """The `tyndall` executable: the add-on preference when set, else `tyndall` on PATH."""
    if configured:
        path = os.path.abspath(os.path.expanduser(configured))
        if not os.path.isfile(path):
            raise TyndallError(
                f"Tyndall binary not found at '{path}' (the add-on's preferences): "
                "set the path to the tyndall executable"
            )
        if not os.access(path, os.X_OK):
            raise TyndallError(f"Tyndall binary '{path}' is not executable")
        return path
    found = shutil.which("tyndall")
    if not found:
        raise TyndallError(
            "Tyndall binary not found: 'tyndall' is not on PATH; set its path in "
            "Edit > Preferences > Add-ons > Tyndall Shafts"
        )
    return found


def default_graphs_folder(binary):
    """The repository's graphs/ next to a binary built in it (target/<profile>/tyndall), or
    the TYNDALL_GRAPHS environment variable."""
    env = os.environ.get("TYNDALL_GRAPHS")
    if env and os.path.isdir(env):
        return env
    if binary:
        repo = os.path.dirname(os.path.dirname(os.path.dirname(os.path.realpath(binary))))
        graphs = os.path.join(repo, "graphs")
        if os.path.isdir(graphs):
            return graphs
    return ""


def list_presets(folders):
    """(absolute path, label) of every .ron graph under the folders: the plate presets first
    (`plate/haze`, which fits any shot, at the top: the default), then by label."""
    out = []
    for folder in folders:
        if not folder or not os.path.isdir(folder):
            continue
        for root, dirs, files in os.walk(folder):
            if root == folder and "lib" in dirs:
                dirs.remove("lib")  # library groups, not presets
            for f in files:
                if f.endswith(".ron"):
                    path = os.path.join(root, f)
                    label = os.path.relpath(path, folder)[: -len(".ron")]
                    out.append((path, label))
    return sorted(out, key=lambda p: (p[1] != "plate/haze", not p[1].startswith("plate/"), p[1]))


def graph_nodes(binary, graph):
    """{id: kind} of the graph's nodes, from `tyndall validate --json`."""
    try:
        o = subprocess.run(
            [binary, "validate", "--json", graph],
            capture_output=True,
            text=True,
            timeout=60,
        )
    except OSError as e:
        raise TyndallError(f"cannot run {binary}: {e}") from e
    if o.returncode != 0:
        raise TyndallError(
            f"tyndall validate {graph} failed (exit {o.returncode}): {last_lines(o.stderr)}"
        )
    try:
        return {n["id"]: n["kind"] for n in json.loads(o.stdout)["nodes"]}
    except (ValueError, KeyError) as e:
        raise TyndallError(f"tyndall validate --json gave no node list: {e}") from e


def last_lines(text, n=3):
    """The last `n` non-empty lines of a process's output, joined (what a report shows)."""
    lines = [l for l in text.strip().splitlines() if l.strip()]
    return " | ".join(lines[-n:]) if lines else "(no output)"


class Job:
    """What one "Render shafts" run needs: the files and the settings from the scene."""

    def __init__(self, binary, graph, out_dir, glb, frames, size, fps, view_layer):
        self.binary = binary
        self.graph = graph
        self.out_dir = out_dir
        self.glb = glb
        self.frames = frames  # (first, last)
        self.size = size  # (width, height)
        self.fps = fps
        self.view_layer = view_layer

    @property
    def plate_pattern(self):
        """Blender's render of the shot, one multi-layer EXR per frame."""
        return os.path.join(self.out_dir, "plate", "plate_####.exr")

    @property
    def shafts_pattern(self):
        """Tyndall's multi-layer EXR per frame (the AovOutput)."""
        return os.path.join(self.out_dir, "shafts_####.exr")

    def frame_file(self, pattern, frame):
        return pattern.replace("####", f"{frame:04d}")

    def command(self, nodes):
        """The `tyndall render` command for this job on a graph with `nodes` ({id: kind}).

        Every Scene node reads the exported glTF; every GBuffer renders at the scene's
        resolution; every VdbVolume reads Blender's axes and voxel centres (`up_axis` z,
        `voxel_centers` blender); a plate preset's `plate` and `plate_depth` ImageInputs read Blender's
        render; the first AovOutput writes the shafts' layers, ImageOutputs a preview."""
        aovs = [i for i, k in nodes.items() if k == "AovOutput"]
        if not aovs:
            raise TyndallError(
                f"preset {os.path.basename(self.graph)} writes no multi-layer EXR (it has no "
                "AovOutput node): choose one of graphs/plate/"
            )
        if not any(k == "Scene" for k in nodes.values()):
            raise TyndallError(f"preset {os.path.basename(self.graph)} has no Scene node")
        first, last = self.frames
        w, h = self.size
        sets = []
        for i, k in sorted(nodes.items()):
            if k == "Scene":
                sets += [f"{i}.path={self.glb}", f"{i}.fps={self.fps}", f"{i}.camera=scene",
                         f"{i}.light=scene"]
            elif k == "GBuffer":
                sets += [f"{i}.width={w}", f"{i}.height={h}"]
            elif k == "VdbVolume":
                # Blender's files (Volume objects, Mantaflow caches) are Z-up with voxel values
                # at cell centres (how Cycles renders them).
                sets += [f"{i}.up_axis=z", f"{i}.voxel_centers=blender"]
            elif k == "ImageOutput":
                sets.append(f"{i}.path={os.path.join(self.out_dir, 'preview_' + i + '_####.png')}")
        sets.append(f"{aovs[0]}.path={self.shafts_pattern}")
        if self.uses_plate(nodes):
            sets += [
                f"plate.path={self.plate_pattern}",
                f"plate.layer={self.view_layer}.Combined",
                f"plate_depth.path={self.plate_pattern}",
                f"plate_depth.layer={self.view_layer}.Depth",
            ]
        cmd = [self.binary, "render", self.graph, "--frames", f"{first}-{last}",
               "--size", f"{w}x{h}", "--progress", "json", "--output-dir", self.out_dir]
        for s in sets:
            cmd += ["--set", s]
        return cmd

    @staticmethod
    def uses_plate(nodes):
        """A plate preset: ImageInputs named `plate` and `plate_depth`."""
        return nodes.get("plate") == "ImageInput" and nodes.get("plate_depth") == "ImageInput"


class Process:
    """A running `tyndall render`: its stdout's JSON progress lines read on a thread, so the
    modal operator can poll without blocking Blender."""

    def __init__(self, cmd):
        try:
            self.p = subprocess.Popen(
                cmd, stdout=subprocess.PIPE, stderr=subprocess.PIPE, text=True
            )
        except OSError as e:
            raise TyndallError(f"cannot run {cmd[0]}: {e}") from e
        self.lines = queue.Queue()
        self.stderr = []
        self.done_frames = 0
        threading.Thread(target=self._read, args=(self.p.stdout, True), daemon=True).start()
        threading.Thread(target=self._read, args=(self.p.stderr, False), daemon=True).start()

    def _read(self, stream, out):
        for line in stream:
            if out:
                self.lines.put(line)
            else:
                self.stderr.append(line)

    def poll(self):
        """(frames finished so far, exit code or None while running)."""
        while True:
            try:
                line = self.lines.get_nowait()
            except queue.Empty:
                break
            try:
                v = json.loads(line)
            except ValueError:
                continue
            if isinstance(v, dict) and "frame" in v:
                self.done_frames += 1
        return self.done_frames, self.p.poll()

    def cancel(self):
        if self.p.poll() is None:
            self.p.kill()
            self.p.wait()

    def error(self):
        return last_lines("".join(self.stderr))
