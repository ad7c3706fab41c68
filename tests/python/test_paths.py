"""Paths from Python: names that are not UTF-8 (given as bytes or as the str of os.fsdecode) open,
come back as os.fsdecode gives them and end in valid JSON; special files in place of a scene, a
sweep file or a .lag file raise the command line's message at once instead of blocking."""
import json
import os
import time

import numpy as np
import pytest

import pardel

SCENE = 'model = "fuel_nav"\n[grid]\nT = 30\nN = 20\n[boundary]\nq0 = [0, 0]\nqN = [6, 5]\n'
LATIN1 = b"sc\xe8ne"  # "scène" in ISO 8859-1: not UTF-8


def latin1_folder(tmp_path):
    folder = os.path.join(os.fsencode(tmp_path), b"dossier_" + LATIN1)
    os.makedirs(folder)
    return folder


def test_scene_path_as_bytes(tmp_path):
    path = os.path.join(latin1_folder(tmp_path), LATIN1 + b".toml")
    with open(path, "w") as f:
        f.write(SCENE)
    scene = pardel.load_scene(path)
    assert os.fsencode(scene.info["path"]) == path


def test_scene_path_as_fsdecoded_str_solves_with_valid_summary(tmp_path):
    path = os.path.join(latin1_folder(tmp_path), LATIN1 + b".toml")
    with open(path, "w") as f:
        f.write(SCENE)
    result = pardel.solve_scene(pardel.load_scene(os.fsdecode(path)))
    assert result.status == "converged"
    # summary.json's text is UTF-8: the byte that is not is written as U+FFFD
    assert result.summary["scene"] == path.replace(b"\xe8", b"\xef\xbf\xbd").decode("utf-8")


def test_sweep_path_and_out_not_utf8(tmp_path):
    folder = latin1_folder(tmp_path)
    with open(os.path.join(folder, b"base.toml"), "w") as f:
        f.write(SCENE)
    sweep_file = os.path.join(folder, LATIN1 + b"_sweep.toml")
    with open(sweep_file, "w") as f:
        f.write('scene = "base.toml"\n')
    out = os.path.join(folder, b"out_" + LATIN1)
    result = pardel.sweep(os.fsdecode(sweep_file), out=os.fsdecode(out))
    assert result.converged == 1
    with open(os.path.join(out, b"sweep.json"), encoding="utf-8") as f:
        assert len(json.load(f)["configurations"]) == 1


def test_lag_file_name_not_utf8(tmp_path):
    lag = os.path.join(latin1_folder(tmp_path), b"mod\xe8le.lag")
    with open(lag, "w") as f:
        f.write("model latin1_file\ncoords x\nL = x'^2/2 - x^2/2\n")
    model = pardel.model(os.fsdecode(lag))
    assert model.name == "latin1_file"
    assert os.fsencode(model.source) == b"mod\xe8le.lag"  # the kernel records the name's bytes
    k = pardel.kernels(model, "trapezoid", 0.5, 0.0, 0.5, [1.0], [1.25])
    assert k["Ld"] == pytest.approx(-0.2578125, abs=1e-15)


def test_solve_with_a_lag_file_name_not_utf8(tmp_path):
    """pardel.solve reads its keyword arguments' scene without writing it as text, so a .lag path
    that is not UTF-8 reaches the model loader as its bytes: the solve is the one of the same model
    under a UTF-8 name, and the continuous motion x = sin t / sin 1 (x'' = -x) within O(h^2)."""
    text = "model latin1_solve\ncoords x\nL = x'^2/2 - x^2/2\n"
    folder = latin1_folder(tmp_path)
    lag, plain = os.path.join(folder, b"mod\xe8le.lag"), os.path.join(folder, b"model.lag")
    for path in (lag, plain):
        with open(path, "w") as f:
            f.write(text)
    reference = pardel.solve(os.fsdecode(plain), q0=[0.0], qN=[1.0], T=1.0, N=16)
    for model in (os.fsdecode(lag), pardel.model(os.fsdecode(lag))):
        result = pardel.solve(model, q0=[0.0], qN=[1.0], T=1.0, N=16)
        assert result.status == "converged"
        assert np.array_equal(result.q, reference.q)
        assert np.max(np.abs(result.q[:, 0] - np.sin(result.t) / np.sin(1.0))) < 1e-3


def test_missing_scene_not_utf8_names_it(tmp_path):
    path = os.path.join(latin1_folder(tmp_path), b"none_" + LATIN1 + b".toml")
    with pytest.raises(pardel.SceneError, match=r"none_sc\\xe8ne.toml: error: cannot open scene file"):
        pardel.load_scene(path)


@pytest.mark.parametrize("where", ["scene", "sweep", "lag"])
def test_fifo_is_refused_at_once(tmp_path, where):
    fifo = str(tmp_path / ("fifo." + ("lag" if where == "lag" else "toml")))
    os.mkfifo(fifo)
    start = time.monotonic()
    if where == "scene":
        with pytest.raises(pardel.SceneError, match="is a FIFO, not a regular file"):
            pardel.load_scene(fifo)
    elif where == "sweep":
        with pytest.raises(pardel.SceneError, match="is a FIFO, not a regular file"):
            pardel.sweep(fifo)
    else:
        with pytest.raises(pardel.ModelError, match="is a FIFO, not a regular file"):
            pardel.model(fifo)
    assert time.monotonic() - start < 10


def test_folder_as_scene_says_so(tmp_path):
    with pytest.raises(pardel.SceneError, match="is a directory, not a scene file"):
        pardel.load_scene(tmp_path)
