"""An install on a machine without a C compiler: setup.py skips the optional cores and the
install goes on, and the package then runs in pure Python and writes the same bytes.

The README's install command must work on a fresh machine with no compiler.  The build is
checked here with a compiler that always fails (CC=/bin/false); the run is checked in a
subprocess where the compiled modules cannot be imported at all (as after that build),
not through GCODE_OPT_PURE_PYTHON (which the other tests use), so native.load's
"not built" path is the one taken."""
import json
import os
import shutil
import subprocess
import sys
from pathlib import Path

import pytest

ROOT = Path(__file__).resolve().parents[1]
SAMPLE = ROOT / "sample_gcode" / "prusa_gyroid.gcode"
CORES = ("_gcode_opt_fwcore", "_gcode_opt_reader", "_gcode_opt_chaincore", "_gcode_opt_emit", "_gcode_opt_curvecore")
KEYS = ("firmware_core", "reader_core", "chain_core", "emit_core", "curve_core")

# Run the CLI with the compiled cores unimportable (what a build without a compiler leaves).
NO_CORES = """
import sys
class _NoCores:
    def find_spec(self, name, path=None, target=None):
        if name.startswith("_gcode_opt_"):
            raise ImportError(f"{name} is not built (test: no C compiler)")
        return None
sys.meta_path.insert(0, _NoCores())
from gcode_opt.cli import main
sys.exit(main(sys.argv[1:]))
"""


def _built(tree: Path):
    return sorted(p.name for p in tree.rglob("*") if p.suffix in (".so", ".pyd") and p.name.startswith("_gcode_opt_"))


def test_build_without_compiler_skips_the_cores(tmp_path):
    pytest.importorskip("setuptools")
    if not os.path.exists("/bin/false"):
        pytest.skip("no /bin/false to stand in for a missing compiler")
    for name in ("setup.py", "pyproject.toml", "README.md"):
        shutil.copy(ROOT / name, tmp_path / name)
    shutil.copytree(ROOT / "gcode_opt", tmp_path / "gcode_opt",
                    ignore=shutil.ignore_patterns("__pycache__", "*.so", "*.pyd"))
    env = dict(os.environ, CC="/bin/false", CXX="/bin/false", LDSHARED="/bin/false")
    r = subprocess.run([sys.executable, "setup.py", "build_ext", "--inplace"], cwd=tmp_path, env=env,
                       capture_output=True, text=True, timeout=300)
    assert r.returncode == 0, r.stdout + r.stderr
    assert _built(tmp_path) == []
    # each of the optional extensions was tried and skipped, not silently left out
    text = r.stdout + r.stderr
    for mod in CORES:
        assert mod in text, text


def _process(tmp_path, tag, code_args):
    out, js = tmp_path / f"{tag}.gcode", tmp_path / f"{tag}.json"
    env = {k: v for k, v in os.environ.items() if k != "GCODE_OPT_PURE_PYTHON"}
    r = subprocess.run([sys.executable, *code_args, "process", str(SAMPLE), "-o", str(out), "--profile", "prusa-mk3s",
                        "-q", "--json", str(js)], cwd=ROOT, env=env, capture_output=True, text=True, timeout=600)
    assert r.returncode == 0, r.stdout + r.stderr
    return out.read_bytes(), json.loads(js.read_text())


def test_run_without_cores_writes_the_same_bytes(tmp_path):
    with_, s_with = _process(tmp_path, "default", ["-m", "gcode_opt"])
    if tuple(s_with[k] for k in KEYS) == ("python",) * len(KEYS):
        pytest.skip("the cores are not built here either: the two runs would take the same path")
    without, s_without = _process(tmp_path, "nocores", ["-c", NO_CORES])
    assert tuple(s_without[k] for k in KEYS) == ("python",) * len(KEYS)
    assert without == with_
