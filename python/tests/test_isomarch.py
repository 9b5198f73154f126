"""The Python package against the command line (docs/python.md).

Run by scripts/python-test.sh (part of scripts/test.sh), which builds the
package into a virtual environment and sets ISOMARCH_BIN to the command
line built from the same tree.
"""

import json
import os
import subprocess
from pathlib import Path

import numpy as np
import OpenEXR
import pytest
from PIL import Image as PILImage

import isomarch

ROOT = Path(__file__).resolve().parents[2]
PDB = ROOT / "tests/data/molecules/1A8O.pdb"


def cli(*args, check=True):
    binary = os.environ.get("ISOMARCH_BIN")
    if not binary:
        pytest.fail("ISOMARCH_BIN is not set: run the Python tests with bash scripts/python-test.sh")
    run = subprocess.run([binary, *map(str, args)], capture_output=True, text=True, cwd=ROOT)
    if check:
        assert run.returncode == 0, run.stderr
    return run


@pytest.fixture(scope="module")
def renderer():
    return isomarch.Renderer()


def png_pixels(path):
    return np.asarray(PILImage.open(path).convert("RGB"))


@pytest.mark.parametrize(
    "scene,method,time,samples",
    [("fig10.ron", None, 0.0, None), ("fig16.ron", "quadratic", 0.5, None), ("default.ron", "segment", 0.0, None), ("fig10.ron", None, 0.0, 4)],
)
def test_a_rendered_array_equals_the_cli_png_pixel_for_pixel(renderer, tmp_path, scene, method, time, samples):
    out = tmp_path / "cli.png"
    args = ["render", ROOT / "scenes" / scene, "--size", "64x48", "--time", time, "-o", out]
    if method:
        args += ["--method", method]
    if samples:
        args += ["--samples", samples]
    cli(*args)
    image = renderer.render(isomarch.Scene.load(ROOT / "scenes" / scene), size=(64, 48), method=method, time=time, samples=samples)
    expected = png_pixels(out)
    assert image.rgba.shape == (48, 64, 4) and image.rgba.dtype == np.uint8
    assert (image.rgba[..., 3] == 255).all()
    assert len(np.unique(expected.reshape(-1, 3), axis=0)) > 20, "the CLI's image is nearly uniform"
    np.testing.assert_array_equal(image.rgba[..., :3], expected)
    # The PNG the package writes is the CLI's, byte for byte.
    assert image.png() == out.read_bytes()
    assert image._repr_png_().startswith(b"\x89PNG")
    assert np.asarray(image).shape == (48, 64, 4)
    assert image.stats["rays"] == 64 * 48 * (samples or 1) and image.stats["steps_per_ray"] > 0


def read_pdb_atoms(path):
    """Heavy atoms of a one-model PDB without alternate locations, read
    here, independently of isomarch's reader: (positions, elements)."""
    positions, elements = [], []
    for line in Path(path).read_text().splitlines():
        if line.startswith(("ATOM  ", "HETATM")):
            # As the file writes it (upper case, `SE`): the package takes
            # symbols in any case, as the readers do.
            element = line[76:78].strip()
            assert line[16] == " ", "the test file has no alternate locations"
            if element.upper() in ("H", "D"):
                continue
            positions.append([float(line[30:38]), float(line[38:46]), float(line[46:54])])
            elements.append(element)
    return np.array(positions), elements


def test_element_symbols_are_taken_in_any_case():
    for upper, table in [("SE", "Se"), ("ZN", "Zn"), ("FE", "Fe"), ("CL", "Cl"), ("se", "Se")]:
        assert isomarch.element_color(upper) == isomarch.element_color(table), upper
        assert isomarch.element_radius(upper) == isomarch.element_radius(table), upper
    assert isomarch.element_radius("SE") == 1.9
    assert isomarch.element_color("ZN") != isomarch.element_color("Xx"), "zinc has Jmol's colour, not the fallback"


def test_from_atoms_with_a_pdbs_coordinates_is_from_molecule_on_that_pdb(renderer):
    positions, elements = read_pdb_atoms(PDB)
    assert "SE" in elements, "1A8O's selenomethionines, as the file writes them"
    radii = [isomarch.element_radius(e) for e in elements]
    assert all(r is not None for r in radii)
    colors = [isomarch.element_color(e) for e in elements]
    atoms = isomarch.Scene.from_atoms(positions, radii, colors)
    # Every atom, its 88 crystal waters too (left out by default).
    molecule = isomarch.Scene.from_molecule(PDB, select="all")
    assert isomarch.Scene.load(PDB).primitive_count == 644 - 88
    assert molecule.summary.endswith("644 atoms, 1 chain"), molecule.summary
    assert atoms.primitive_count == molecule.primitive_count == len(elements) == 644
    a = renderer.render(atoms, size=(48, 48))
    m = renderer.render(molecule, size=(48, 48))
    assert (m.depth < np.inf).sum() > 300, "the molecule covers too little of the frame to compare"
    # The same scene: the index's lists are sorted by primitive index, so
    # every run sums in the same order and the renders are equal bit for
    # bit (as the AOV test finds of the command line's).
    differ = (a.rgba != m.rgba).any(axis=-1).sum()
    assert differ == 0, f"{differ} pixels differ"
    np.testing.assert_array_equal(a.depth, m.depth)
    np.testing.assert_array_equal(a.steps, m.steps)
    # Any array-like of any float type: float32 positions (an MDAnalysis
    # selection's) and lists.
    assert isomarch.Scene.from_atoms(positions.astype(np.float32), np.float32(radii), None).primitive_count == 644
    assert isomarch.Scene.from_atoms(positions.tolist(), radii).primitive_count == 644


@pytest.mark.parametrize("source", ["scenes/fig10.ron", "tests/data/molecules/1A8O.pdb"])
def test_depth_steps_and_normals_equal_the_exr_aovs(renderer, tmp_path, source):
    exr = tmp_path / "aovs.exr"
    cli("render", ROOT / source, "--size", "40x40", "-o", tmp_path / "m.png", "--aov", "depth,steps,normal", "--aov-output", exr)
    scene = isomarch.Scene.from_molecule(ROOT / source) if source.endswith(".pdb") else isomarch.Scene.load(ROOT / source)
    image = renderer.render(scene, size=(40, 40))
    with OpenEXR.File(str(exr)) as f:
        channels = f.channels()
        exr_depth, exr_steps = np.asarray(channels["Z"].pixels), np.asarray(channels["steps"].pixels)
        exr_normals = np.stack([np.asarray(channels[f"normal.{a}"].pixels) for a in "XYZ"], axis=-1)
    # Without the spatial index every run sums the same terms in the same
    # order; with it (1A8O), each cell's list is sorted by primitive index
    # (lists of up to 255 entries; 1A8O's are shorter), so again: equal to
    # the bit.
    np.testing.assert_array_equal(image.depth, exr_depth)
    np.testing.assert_array_equal(image.steps.astype(np.float32), exr_steps)
    np.testing.assert_array_equal(image.normals, exr_normals)
    hit = image.depth < np.inf
    assert 100 < hit.sum() < 1600 and (image.steps[hit] > 0).all()
    lengths = np.linalg.norm(image.normals[hit], axis=-1)
    assert np.abs(lengths - 1).max() < 1e-4


def test_bad_input_raises_the_clis_message(tmp_path):
    bad = tmp_path / "bad.ron"
    bad.write_text("Scene(camera: (eye: (0, 0, 5)))\n")
    message = cli("render", bad, "-o", tmp_path / "x.png", check=False).stderr.strip()
    assert message.startswith("error: ") and "\n" not in message, message
    with pytest.raises(isomarch.IsomarchError) as e:
        isomarch.Scene.load(bad)
    assert str(e.value) == message[len("error: "):]
    missing = tmp_path / "missing.pdb"
    message = cli("render", missing, "-o", tmp_path / "x.png", check=False).stderr.strip()
    with pytest.raises(isomarch.IsomarchError) as e:
        isomarch.Scene.from_molecule(missing)
    assert str(e.value) == message[len("error: "):]
    with pytest.raises(isomarch.IsomarchError, match="3 positions but 2 radii"):
        isomarch.Scene.from_atoms(np.zeros((3, 3)), [1.5, 1.5])
    with pytest.raises(isomarch.IsomarchError, match="radius 1 must be positive"):
        isomarch.Scene.from_atoms(np.zeros((2, 3)), [1.5, -1.0])
    with pytest.raises(isomarch.IsomarchError, match="invalid method"):
        isomarch.Renderer().render(isomarch.Scene.load(ROOT / "scenes/fig10.ron"), size=(8, 8), method="nope")


def rss_kib():
    for line in Path("/proc/self/status").read_text().splitlines():
        if line.startswith("VmRSS:"):
            return int(line.split()[1])
    raise AssertionError("no VmRSS in /proc/self/status")


def test_a_renderer_renders_twenty_frames_without_leaking(renderer):
    scene = isomarch.Scene.load(ROOT / "scenes/default.ron")
    frames = []
    for i in range(20):
        image = renderer.render(scene, size=(192, 192), time=0.1 * i)
        frames.append(image.rgba.sum())
        if i == 4:
            settled = rss_kib()
    grown = rss_kib() - settled
    # Each frame's arrays (0.8 MiB at 192x192) are dropped; a leak of
    # them, of the GPU readback (64 bytes a pixel: 2.25 MiB a frame), or
    # of a renderer per frame is 12 MiB or more over 15 frames.
    assert grown < 8 * 1024, f"RSS grew by {grown} KiB over 15 frames"


def test_bench_rows_equal_the_clis(renderer, tmp_path):
    path = tmp_path / "bench.json"
    cli("bench", ROOT / "scenes/fig10.ron", "--methods", "segment,quadratic-taylor", "--rays", "1024", "--json", path)
    expected = json.loads(path.read_text())
    report = renderer.bench(isomarch.Scene.load(ROOT / "scenes/fig10.ron"), ["segment", "quadratic-taylor"], rays=1024)
    assert [r["method"] for r in report["methods"]] == ["segment", "quadratic-taylor"]
    assert report["reference_hit_rate"] == expected["reference_hit_rate"] > 0.2
    for mine, theirs in zip(report["methods"], expected["methods"]):
        for key, value in theirs.items():
            # Times differ between runs; everything counted is equal.
            if not any(word in key for word in ("ns_", "time", "gpu_ms")):
                assert mine[key] == value, f"{mine['method']}: {key} {mine[key]} against the CLI's {value}"
    with pytest.raises(isomarch.IsomarchError, match="invalid method"):
        renderer.bench(isomarch.Scene.load(ROOT / "scenes/fig10.ron"), ["nope"])


def test_any_hit_bench_and_render_statistics_equal_the_clis(renderer, tmp_path):
    path = tmp_path / "any-hit.json"
    methods = ["segment", "quadratic-taylor"]
    cli("bench", ROOT / "scenes/fig10.ron", "--any-hit", "--methods", ",".join(methods), "--rays", "512", "--json", path)
    expected = json.loads(path.read_text())
    report = renderer.bench(isomarch.Scene.load(ROOT / "scenes/fig10.ron"), methods, rays=512, any_hit=True)
    assert report["any_hit"] == expected["any_hit"] and report["any_hit"]["ao_rays"] > 0
    for mine, theirs in zip(report["methods"], expected["methods"]):
        assert mine["any_hit"] == theirs["any_hit"], mine["method"]
        assert mine["steps_per_ray"] == theirs["steps_per_ray"], mine["method"]
    # A scene that asks for shadows and occlusion reports their rays apart.
    text = (ROOT / "scenes/fig10.ron").read_text().replace("Scene(", "Scene(\n    shadows: true,\n    ao: (samples: 4, distance: 2.0),", 1)
    lit = tmp_path / "lit.ron"
    lit.write_text(text)
    stats = tmp_path / "stats.json"
    cli("render", lit, "-o", tmp_path / "lit.png", "--size", "48x48", "--stats", stats)
    image = renderer.render(isomarch.Scene.load(lit), size=(48, 48))
    theirs = json.loads(stats.read_text())["any_hit"]
    mine = image.stats["any_hit"]
    assert mine["ao_rays"] == theirs["ao_rays"] > 0 and mine["shadow_rays"] == theirs["shadow_rays"] > 0
    assert mine["ao_steps_per_ray"] == theirs["ao_steps_per_ray"]


def test_tradeoff_rows_equal_the_clis_csv(renderer, tmp_path):
    cli("tradeoff", ROOT / "scenes/fig10.ron", "--quick", "-o", tmp_path)
    lines = (tmp_path / "tradeoff.csv").read_text().splitlines()
    header = lines[0].split(",")
    expected = [dict(zip(header, line.split(","))) for line in lines[1:]]
    rows = renderer.tradeoff(isomarch.Scene.load(ROOT / "scenes/fig10.ron"), min_steps=[0.01, 0.1], max_steps=[32, 1000], rays=1024)
    assert len(rows) == len(expected) == 8
    for mine, theirs in zip(rows, expected):
        assert (mine["method"], mine["min_step"], mine["max_steps"]) == (theirs["method"], float(theirs["min_step"]), int(theirs["max_steps"]))
        # Within the CSV's rounding: 4 decimals of steps, 2 of evaluations, 6 of rates.
        for key, half in (("steps_per_ray", 5e-5), ("evals_per_ray", 5e-3), ("miss_rate", 5e-7), ("false_hit_rate", 5e-7)):
            assert abs(mine[key] - float(theirs[key])) <= half, (key, mine, theirs)
        if mine["max_steps"] == 1000:
            assert mine["miss_rate"] == 0 and mine["false_hit_rate"] == 0, mine


def test_a_trajectory_frame_renders_as_the_clis_batch_frame(renderer, tmp_path):
    top, traj = ROOT / "tests/data/trajectories/adk.psf", ROOT / "tests/data/trajectories/adk_dims.dcd"
    frames = isomarch.Trajectory(top, traj, framing="all")
    assert len(frames) == 98 and "1656 atoms" in frames.summary
    assert abs(frames[0].time_ps - 1.0) < 1e-6 and abs(frames[-1].time_ps - 98.0) < 1e-5
    cli("render", top, traj, "--framing", "all", "--frames", "0..3", "-o", tmp_path / "f_#.png", "--size", "40x40")
    for k, scene in enumerate(frames):
        if k == 3:
            break
        image = renderer.render(scene, size=(40, 40))
        assert image.png() == (tmp_path / f"f_{k}.png").read_bytes(), f"frame {k}"
    with pytest.raises(IndexError):
        frames[98]
    with pytest.raises(isomarch.IsomarchError, match="atoms where the topology has 3341"):
        isomarch.Trajectory(top, ROOT / "tests/data/trajectories/YiiP_lipids.xtc")


def test_the_module_shows_its_api_and_its_version():
    public = {name for name in dir(isomarch) if not name.startswith("_")}
    assert public == set(isomarch.__all__), public ^ set(isomarch.__all__)
    version = cli("--version").stdout.split()[-1]
    assert isomarch.__version__ == version, (isomarch.__version__, version)
    assert isomarch.DEFAULT_SEED == 20230601


def test_molecule_options_take_the_clis_defaults_and_checks(tmp_path):
    # Fields left out are the command line's defaults: the scene written
    # by `isomarch scene` with no flags is the one made with no options.
    out = tmp_path / "1a8o.ron"
    cli("scene", PDB, "-o", out)
    default = isomarch.Scene.from_molecule(PDB)
    assert default.primitive_count == isomarch.Scene.load(out).primitive_count
    options = isomarch.MoleculeOptions()
    assert (options.hydrogens, options.coloring, options.turntable) == (False, "element", None)
    # Some of them given: the same as `isomarch scene --sharpness 3 --color chain`.
    cli("scene", PDB, "-o", out, "--sharpness", "3", "--color", "chain", "--hydrogens")
    given = isomarch.MoleculeOptions(sharpness=3, coloring="chain", hydrogens=True)
    assert (given.sharpness, given.coloring, given.hydrogens) == (3.0, "chain", True)
    renderer = isomarch.Renderer()
    a = renderer.render(isomarch.Scene.from_molecule(PDB, given), size=(32, 32))
    b = renderer.render(isomarch.Scene.load(out), size=(32, 32))
    assert np.array_equal(a.rgba, b.rgba)
    assert np.array_equal(renderer.render(isomarch.Scene.from_molecule(PDB, sharpness=3, coloring="chain", hydrogens=True), size=(32, 32)).rgba, a.rgba)
    # The command line's message for a bad value, and its names for a choice.
    message = cli("scene", PDB, "-o", out, "--sharpness=-1", check=False).stderr.strip()
    with pytest.raises(isomarch.IsomarchError) as e:
        isomarch.MoleculeOptions(sharpness=-1)
    assert str(e.value) == message[len("error: "):]
    with pytest.raises(isomarch.IsomarchError, match='expected one of "element", "chain", "bfactor", "occupancy", "restype", "resname", "values", "none", got "chian"'):
        isomarch.MoleculeOptions(coloring="chian")
    with pytest.raises(isomarch.IsomarchError, match='expected one of "first", "all", got "every"'):
        isomarch.Trajectory(PDB, framing="every")
    with pytest.raises(TypeError):
        isomarch.MoleculeOptions(colour="chain")
    with pytest.raises(TypeError, match="not both"):
        isomarch.Scene.from_molecule(PDB, given, iso=2)


def test_trajectories_default_framing_xtc_input_and_models_alone(renderer, tmp_path):
    # The default framing is "first": frame 0 renders as the command line's
    # without --framing, and otherwise than with --framing all.
    top, traj = ROOT / "tests/data/trajectories/adk.psf", ROOT / "tests/data/trajectories/adk_dims.dcd"
    cli("render", top, traj, "--frame", "0", "-o", tmp_path / "first.png", "--size", "40x40")
    default = renderer.render(isomarch.Trajectory(top, traj)[0], size=(40, 40))
    assert default.png() == (tmp_path / "first.png").read_bytes(), "the default framing is not --framing first"
    assert default.png() != renderer.render(isomarch.Trajectory(top, traj, framing="all")[0], size=(40, 40)).png()
    # XTC input: YiiP's 5 frames, frame 2 as `render TOP TRAJ --frame 2`.
    gro, xtc = ROOT / "tests/data/trajectories/YiiP_lipids.gro.gz", ROOT / "tests/data/trajectories/YiiP_lipids.xtc"
    frames = isomarch.Trajectory(gro, xtc)
    assert len(frames) == 5, len(frames)
    cli("render", gro, xtc, "--frame", "2", "-o", tmp_path / "yiip2.png", "--size", "40x40")
    assert renderer.render(frames[2], size=(40, 40)).png() == (tmp_path / "yiip2.png").read_bytes(), "XTC frame 2"
    # A file of several models alone: its models are the frames.
    models = tmp_path / "nmr.pdb"
    atom = "ATOM  {:>5} {:<4} GLY A   1    {:>8.3f}{:>8.3f}{:>8.3f}  1.00  0.00          {:>2}\n"
    text = ""
    for m in range(3):
        text += f"MODEL     {m + 1:>4}\n"
        for i, (name, el, x) in enumerate([("N", "N", 0.0), ("CA", "C", 1.45), ("C", "C", 2.9)]):
            text += atom.format(i + 1, f" {name}", x + m, 0.0, 0.0, el)
        text += "ENDMDL\n"
    models.write_text(text + "END\n")
    alone = isomarch.Trajectory(models)
    assert len(alone) == 3, len(alone)
    cli("render", models, "--frame", "1", "-o", tmp_path / "model1.png", "--size", "32x32")
    assert renderer.render(alone[1], size=(32, 32)).png() == (tmp_path / "model1.png").read_bytes(), "model 1"
    assert renderer.render(alone[0], size=(32, 32)).png() != (tmp_path / "model1.png").read_bytes(), "models 0 and 1 alike"


def test_frames_read_ahead_are_the_frames_indexed(renderer):
    # Iteration and frames() read each frame on the reader's thread, ahead
    # of the caller: the same scenes, times and saved frames as t[k], in
    # the order asked for (XTC, a list out of order, negative numbers,
    # interpolated frames).
    gro, xtc = ROOT / "tests/data/trajectories/YiiP_lipids.gro.gz", ROOT / "tests/data/trajectories/YiiP_lipids.xtc"
    t = isomarch.Trajectory(gro, xtc, interpolate=1)
    assert len(t) == 9, len(t)
    for order in [None, [4, 0, 8, 3], [-1, 1]]:
        ahead = list(t.frames(order))
        indexed = [t[k] for k in (range(len(t)) if order is None else order)]
        assert len(ahead) == len(indexed)
        for a, b in zip(ahead, indexed):
            assert (a.time_ps, a.between) == (b.time_ps, b.between), (order, a.between, b.between)
            assert renderer.render(a, size=(24, 24)).png() == renderer.render(b, size=(24, 24)).png(), (order, a.between)
    # Frames that differ, not one frame over and over.
    pngs = {renderer.render(s, size=(24, 24)).png() for s in t}
    assert len(pngs) > 4, len(pngs)
    with pytest.raises(isomarch.IsomarchError):
        list(t.frames([9]))


def test_selections_and_values_per_frame_equal_the_clis(renderer, tmp_path):
    # A selection as the command line's --select: the same scene.
    out = tmp_path / "sel.ron"
    cli("scene", PDB, "-o", out, "--select", "resid 151 to 170 and not water")
    chosen = isomarch.Scene.from_molecule(PDB, select="resid 151 to 170 and not water", color="bfactor")
    assert chosen.primitive_count == isomarch.Scene.load(out).primitive_count == 180, chosen.primitive_count
    assert isomarch.MoleculeOptions().select == "not (water or ion)"
    message = cli("scene", PDB, "-o", out, "--select", "chian A", check=False).stderr.strip()
    with pytest.raises(isomarch.IsomarchError) as e:
        isomarch.MoleculeOptions(select="chian A")
    assert str(e.value) == message[len("error: "):].replace("--select: ", "select: ")
    # Values per frame of a trajectory (T x N): a CSV of one row per frame
    # for the command line, the same numbers as a numpy array for Python,
    # frame by frame the same image.
    top, traj = ROOT / "tests/data/trajectories/adk.psf", ROOT / "tests/data/trajectories/adk_dims.dcd"
    values = np.random.default_rng(7).uniform(0.0, 100.0, size=(3, 3341))
    csv = tmp_path / "values.csv"
    np.savetxt(csv, values, delimiter=",", fmt="%.17g")
    cli("render", top, traj, "--color-values", csv, "--frames", "0..3", "-o", tmp_path / "v_#.png", "--size", "40x40")
    frames = isomarch.Trajectory(top, traj, values=values)
    for k in range(3):
        assert renderer.render(frames[k], size=(40, 40)).png() == (tmp_path / f"v_{k}.png").read_bytes(), f"frame {k}"
    # The colours follow the rows: frame 1 with row 0's values differs.
    same = isomarch.Trajectory(top, traj, values=values[[0, 0, 0]])
    assert renderer.render(same[1], size=(40, 40)).png() != (tmp_path / "v_1.png").read_bytes(), "frame 1 took row 0's colours"
    # Frame k takes row k: it renders as frame k of a trajectory whose every
    # row is row k (the palette over the same range, 0:100, so that only the
    # row taken can differ), and otherwise than with any other row.
    ranged = isomarch.Trajectory(top, traj, values=values, range=(0.0, 100.0))
    for k in range(3):
        shown = renderer.render(ranged[k], size=(40, 40)).png()
        for j in range(3):
            row_j = isomarch.Trajectory(top, traj, values=values[[j, j, j]], range=(0.0, 100.0))
            alike = renderer.render(row_j[k], size=(40, 40)).png() == shown
            assert alike == (j == k), f"frame {k} renders {'as' if alike else 'otherwise than'} with row {j}'s values everywhere"
    with pytest.raises(isomarch.IsomarchError, match="3 rows of values, none for frame 5"):
        frames[5]


def test_a_viewed_scene_renders_as_the_clis_view_flags(renderer, tmp_path):
    flags = ["--turn", "y:90", "--turn", "x:-20", "--zoom", "1.3", "--fov", "25", "--ortho", "--clip", "near:60", "--background", "white"]
    cli("render", PDB, "-o", tmp_path / "cli.png", "--size", "40x40", *flags)
    scene = isomarch.Scene.from_molecule(PDB).viewed(turn=["y:90", "x:-20"], zoom=1.3, fov=25, ortho=True, clip="near:60", background="white")
    assert renderer.render(scene, size=(40, 40)).png() == (tmp_path / "cli.png").read_bytes()
    plain = renderer.render(isomarch.Scene.from_molecule(PDB), size=(40, 40)).png()
    assert plain != (tmp_path / "cli.png").read_bytes(), "the view changed nothing"
    message = cli("render", PDB, "-o", tmp_path / "x.png", "--turn", "w:90", check=False).stderr
    with pytest.raises(isomarch.IsomarchError) as e:
        isomarch.Scene.from_molecule(PDB).viewed(turn=["w:90"])
    # The same reason, named for the flag on the command line and for the keyword in Python.
    reason = str(e.value)[len("turn: "):]
    assert str(e.value).startswith("turn: ") and reason in message, (str(e.value), message)


def test_depth_cue_outlines_and_a_transparent_background_equal_the_clis(renderer, tmp_path):
    flags = ["--depth-cue", "0:0.7", "--outline", "2", "--outline-color", "white", "--samples", "4"]
    cli("render", PDB, "-o", tmp_path / "look.png", "--size", "40x40", *flags)
    scene = isomarch.Scene.from_molecule(PDB)
    look = renderer.render(scene, size=(40, 40), samples=4, depth_cue="0:0.7", outline=2, outline_color="white")
    assert look.png() == (tmp_path / "look.png").read_bytes()
    assert look.png() != renderer.render(scene, size=(40, 40), samples=4).png(), "the effects changed nothing"
    cli("render", PDB, "-o", tmp_path / "clear.png", "--size", "40x40", "--samples", "4", "--transparent-background")
    clear = renderer.render(scene, size=(40, 40), samples=4, transparent_background=True)
    assert clear.png() == (tmp_path / "clear.png").read_bytes()
    alpha = clear.rgba[..., 3]
    assert (alpha == 0).any() and (alpha == 255).any() and ((alpha > 0) & (alpha < 255)).any(), "no edge with partial coverage"
    message = cli("render", PDB, "-o", tmp_path / "x.png", "--outline", "0", check=False).stderr.strip()
    assert len(message.splitlines()) == 1, message
    with pytest.raises(isomarch.IsomarchError) as e:
        renderer.render(scene, size=(8, 8), outline=0)
    assert str(e.value) == message[len("error: "):]


def test_a_transparent_backgrounds_alpha_is_an_edges_coverage(renderer, tmp_path):
    # A plane facing an orthographic camera (a view 1.6 high, so 8 wide on
    # 40x8 pixels), cut by the scene's box at x = 0.37: a straight vertical
    # edge at (0.37 + 4) / 8 * 40 = 21.85 pixels from the left, whatever the
    # plane's depth. With 16 samples (one in each sixteenth of a pixel's
    # width), each pixel's alpha is its coverage clamp(21.85 - x, 0, 1)
    # within 1/16 and half an 8-bit level; covered pixels keep the surface's
    # colour (0.8 linear, not blended with the background), uncovered ones
    # are (0, 0, 0, 0). The command line makes the same PNG.
    path = tmp_path / "edge.ron"
    path.write_text(
        """Scene(
    camera: (eye: (0.0, 0.0, 10.0), target: (0.0, 0.0, 0.0), fov_y: 30.0, resolution: (40, 8),
             projection: Orthographic(height: 1.6)),
    background: (0.1, 0.1, 0.1),
    ambient: (0.8, 0.8, 0.8),
    surface: (1.0, 1.0, 1.0),
    lights: [(direction: (1.0, 0.0, 0.0))],
    iso: 0.5,
    bounds: Some((min: (-100.0, -100.0, -2.0), max: (0.37, 100.0, 2.0))),
    marching: (method: "quadratic-taylor", min_step: 0.001),
    groups: [(primitives: [Plane(normal: (0.0, 0.0, 1.0), offset: 0.0, radius: 1.0)])],
)"""
    )
    image = renderer.render(isomarch.Scene.load(path), samples=16, transparent_background=True)
    cli("render", path, "-o", tmp_path / "edge.png", "--samples", "16", "--transparent-background")
    assert image.png() == (tmp_path / "edge.png").read_bytes(), "Python's PNG is not the command line's"
    rgba = image.rgba.astype(np.float64)
    assert rgba.shape == (8, 40, 4)
    edge = (0.37 + 4.0) / 8.0 * 40.0
    coverage = np.clip(edge - np.arange(40.0), 0.0, 1.0)[None, :].repeat(8, axis=0)
    error = np.abs(rgba[..., 3] / 255.0 - coverage)
    assert error.max() <= 1.0 / 16.0 + 0.5 / 255.0 + 1e-9, f"alpha off the coverage by {error.max():.4f} at {np.unravel_index(error.argmax(), error.shape)}"
    assert ((rgba[..., 3] > 0) & (rgba[..., 3] < 255)).sum() == 8, "not one column of partly covered pixels"
    surface = round(255 * (1.055 * 0.8 ** (1 / 2.4) - 0.055))
    covered = rgba[..., 3] > 0
    assert (np.abs(rgba[covered][:, :3] - surface) <= 1).all(), f"covered pixels not the surface's colour {surface}"
    assert (rgba[~covered] == 0).all(), "uncovered pixels not (0, 0, 0, 0)"


ADK = (ROOT / "tests/data/trajectories/adk.psf", ROOT / "tests/data/trajectories/adk_dims.dcd")


@pytest.mark.parametrize("ext", ["mp4", "gif"])
def test_a_trajectory_movie_equals_the_clis_byte_for_byte(renderer, tmp_path, ext):
    cli("render", *ADK, "--frames", "0..6", "--size", "64x64", "-o", tmp_path / f"cli.{ext}")
    frames = isomarch.Trajectory(*ADK)
    frames.movie(tmp_path / f"py.{ext}", frames=range(6), size=(64, 64), renderer=renderer)
    cli_bytes, py_bytes = (tmp_path / f"cli.{ext}").read_bytes(), (tmp_path / f"py.{ext}").read_bytes()
    assert len(py_bytes) > 1000 and py_bytes == cli_bytes, f"{ext}: Python's movie ({len(py_bytes)} bytes) is not the CLI's ({len(cli_bytes)})"
    assert sorted(p.name for p in tmp_path.iterdir()) == sorted([f"cli.{ext}", f"cli.{ext}.csv", f"py.{ext}"])


def test_an_interpolated_movie_equals_the_clis_and_says_which_saved_frames(renderer, tmp_path):
    cli("render", *ADK, "--interpolate", "3", "--frames", "0..6", "--size", "64x64", "-o", tmp_path / "cli.gif")
    frames = isomarch.Trajectory(*ADK)
    assert len(frames) == 98
    frames.movie(tmp_path / "py.gif", frames=range(6), size=(64, 64), renderer=renderer, interpolate=3)
    assert len(frames) == 98, "interpolate= applies to the movie only"
    cli_bytes, py_bytes = (tmp_path / "cli.gif").read_bytes(), (tmp_path / "py.gif").read_bytes()
    assert len(py_bytes) > 1000 and py_bytes == cli_bytes, f"Python's movie ({len(py_bytes)} bytes) is not the CLI's ({len(cli_bytes)})"
    smooth = isomarch.Trajectory(*ADK, interpolate=3)
    assert len(smooth) == 4 * 97 + 1
    assert smooth[6].between == (1, 2, 0.5) and smooth[4].between == (1, 1, 0.0)
    rows = (tmp_path / "cli.gif.csv").read_text().splitlines()
    head = rows[0].split(",")
    row = dict(zip(head, rows[1 + 5].split(",")))
    assert (row["saved_from"], row["saved_to"], row["fraction"]) == ("1", "2", "0.250000"), row


def test_a_gro_split_by_its_box_is_made_whole_with_a_note(renderer):
    gro = ROOT / "tests/data/trajectories/adk_oplsaa.gro.gz"
    xtc = ROOT / "tests/data/trajectories/adk_oplsaa.xtc"
    whole = isomarch.Trajectory(gro, xtc)
    assert any("split by the periodic box" in w for w in whole.warnings), whole.warnings
    none = isomarch.Trajectory(gro, xtc, pbc="none")
    assert not any("periodic box" in w for w in none.warnings)
    single = isomarch.Scene.from_molecule(gro)
    assert any("split by the periodic box" in w for w in single.warnings), single.warnings
    # Framed on the molecule: whole, it fills more of the picture.
    covered = [(renderer.render(t[0], (32, 32)).rgba != renderer.render(t[0], (32, 32)).rgba[0, 0]).any(axis=-1).sum() for t in (whole, none)]
    assert covered[0] > covered[1], covered


def test_a_movie_without_ffmpeg_is_refused_before_any_frame(tmp_path, monkeypatch):
    frames = isomarch.Trajectory(*ADK)
    monkeypatch.setenv("PATH", str(tmp_path / "nothing"))
    with pytest.raises(isomarch.IsomarchError, match=r"needs ffmpeg.*apt-get install ffmpeg"):
        frames.movie(tmp_path / "a.mp4", size=(64, 64))
    with pytest.raises(isomarch.IsomarchError, match="even width and height"):
        frames.movie(tmp_path / "a.gif.mp4", size=(63, 64))
    assert list(tmp_path.iterdir()) == []


def test_a_trajectory_shows_as_an_inline_video_in_a_notebook(tmp_path, monkeypatch):
    import base64
    import re

    frames = isomarch.Trajectory(*ADK)
    frames.repr_frames, frames.repr_size = 4, (48, 48)
    html = frames._repr_html_()
    m = re.fullmatch(r'<video controls autoplay loop muted playsinline width="48" src="data:video/mp4;base64,([A-Za-z0-9+/=]+)"></video>', html)
    assert m, html[:200]
    frames.movie(tmp_path / "same.mp4", frames=range(4), size=(48, 48))
    assert base64.b64decode(m.group(1)) == (tmp_path / "same.mp4").read_bytes(), "the inline MP4 is not movie()'s"
    # Where ffmpeg is not installed: an animated GIF.
    monkeypatch.setenv("PATH", str(tmp_path / "nothing"))
    html = frames._repr_html_()
    m = re.fullmatch(r'<img width="48" src="data:image/gif;base64,([A-Za-z0-9+/=]+)"/>', html)
    assert m, html[:200]
    gif = PILImage.open(__import__("io").BytesIO(base64.b64decode(m.group(1))))
    assert gif.format == "GIF" and gif.size == (48, 48) and gif.n_frames == 4
