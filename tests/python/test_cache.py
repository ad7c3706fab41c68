"""The model cache as Python uses it (pardel.lag_cache_dir(), .lag text written to lag-text/): an
edited lag-text file is never compiled, a cache folder others can write or a link is refused with the
path and the reason, and with no cache variable and no HOME each process has a private folder of
its own, removed at exit."""
import os
import stat
import subprocess
import sys
import uuid

import pytest

import pardel


def _text(name):
    return ("model %s\norder 1\ncoords x\nparam k = 2\nL = 1/2*x'^2 - k/2*x^2\n"
            "discretizations midpoint\n" % name)


def _compiled_model_names(cache):
    """The model names of the complete entries in the cache folder `cache`."""
    names = set()
    for entry in os.listdir(cache):
        path = os.path.join(cache, entry, "model_name.txt")
        if os.path.isfile(path):
            with open(path, encoding="utf-8") as f:
                names.add(f.read().strip())
    return names


def test_edited_lag_text_file_is_never_compiled(monkeypatch, tmp_path):
    monkeypatch.setenv("PARDEL_CACHE_DIR", str(tmp_path / "cache"))
    name = "text_%s" % uuid.uuid4().hex[:8]
    text = _text(name)
    first = pardel.model(text)
    assert first.name == name
    path = first.spec
    assert os.path.dirname(path) == os.path.join(pardel.lag_cache_dir(), "lag-text")
    assert stat.S_IMODE(os.lstat(path).st_mode) == 0o600
    # Someone edits the cached text: another model, another parameter.
    with open(path, "w", encoding="utf-8") as f:
        f.write(text.replace("model " + name, "model planted").replace("k = 2", "k = 9"))
    again = pardel.model(text)
    assert again.name == name and again.params == {"k": 2.0}
    with open(path, encoding="utf-8") as f:
        assert f.read() == text
    assert "planted" not in _compiled_model_names(pardel.lag_cache_dir())
    assert not [n for n in os.listdir(os.path.dirname(path)) if ".tmp." in n]


@pytest.mark.parametrize("mode", [0o770, 0o707])
def test_cache_writable_by_others_is_refused(monkeypatch, tmp_path, mode):
    cache = tmp_path / "cache"
    cache.mkdir()
    os.chmod(cache, mode)
    monkeypatch.setenv("PARDEL_CACHE_DIR", str(cache))
    with pytest.raises(pardel.ModelError) as info:
        pardel.model(_text("refused_%s" % uuid.uuid4().hex[:8]))
    message = str(info.value)
    assert "refusing the model cache folder %s: it is writable by" % cache in message
    assert "(mode %04o)" % mode in message
    assert os.listdir(cache) == []


def test_cache_that_is_a_symbolic_link_is_refused(monkeypatch, tmp_path):
    target = tmp_path / "elsewhere"
    target.mkdir(mode=0o700)
    (tmp_path / "cache").symlink_to(target)
    monkeypatch.setenv("PARDEL_CACHE_DIR", str(tmp_path / "cache"))
    with pytest.raises(pardel.ModelError, match="it is a symbolic link"):
        pardel.model(_text("linked_%s" % uuid.uuid4().hex[:8]))
    assert os.listdir(target) == []


_NO_CACHE_VARIABLES = """
import os, stat, sys
import pardel
root = pardel.lag_cache_dir()
m = pardel.model(sys.argv[1])
st = os.lstat(root)
print(root, stat.S_IMODE(st.st_mode), st.st_uid == os.geteuid(), m.name)
"""


def test_no_cache_variables_give_each_process_a_private_folder(tmp_path):
    env = {k: v for k, v in os.environ.items() if k not in ("PARDEL_CACHE_DIR", "XDG_CACHE_HOME", "HOME")}
    env["TMPDIR"] = str(tmp_path)
    # The folder an older pardel used, planted by someone else: never used.
    fixed = tmp_path / ("pardel-cache-%d" % os.getuid())
    fixed.mkdir(mode=0o777)
    os.chmod(fixed, 0o777)
    name = "private_%s" % uuid.uuid4().hex[:8]
    roots = []
    for _ in range(2):
        out = subprocess.run([sys.executable, "-c", _NO_CACHE_VARIABLES, _text(name)], env=env,
                             capture_output=True, text=True, timeout=120)
        assert out.returncode == 0, out.stderr
        root, mode, own, model_name = out.stdout.split()
        assert model_name == name
        assert mode == str(0o700) and own == "True"
        assert os.path.dirname(root) == str(tmp_path) and root != str(fixed)
        assert not os.path.exists(root), "the private folder outlived its process"
        roots.append(root)
    assert roots[0] != roots[1]
    assert os.listdir(fixed) == []
    assert sorted(os.listdir(tmp_path)) == [fixed.name]
