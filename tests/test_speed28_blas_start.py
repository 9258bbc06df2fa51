"""The command line sets OPENBLAS_NUM_THREADS=1 before numpy loads (blas.one_thread_from_start):
OpenBLAS then starts no thread pool whose threads spin ~0.1 s of CPU at numpy's import.
That only works if importing the command line does not load numpy, and it must leave a
user's own thread setting alone."""
import importlib
import subprocess
import sys

from gcode_opt import blas


def test_sets_one_thread_when_unset():
    env = {"PATH": "/usr/bin"}
    got = blas.one_thread_from_start(env) if "numpy" not in sys.modules else None
    if got is None:                        # numpy already loaded in this test process: a fresh one
        code = ("import sys; from gcode_opt import blas; env = {}; "
                "print(blas.one_thread_from_start(env), env)")
        out = subprocess.run([sys.executable, "-c", code], capture_output=True, text=True, check=True).stdout
        assert out.strip() == "True {'OPENBLAS_NUM_THREADS': '1'}"
    else:
        assert got is True and env["OPENBLAS_NUM_THREADS"] == "1"


def test_user_setting_and_loaded_numpy_left_alone():
    importlib.import_module("numpy")     # loaded: too late to matter, nothing set
    env = {}
    assert blas.one_thread_from_start(env) is False and env == {}
    code = ("from gcode_opt import blas; import sys; "
            "envs = [{'OPENBLAS_NUM_THREADS': '2'}, {'OMP_NUM_THREADS': '3'}, {'GOTO_NUM_THREADS': '2'}]; "
            "print([blas.one_thread_from_start(e) for e in envs], envs)")
    out = subprocess.run([sys.executable, "-c", code], capture_output=True, text=True, check=True).stdout
    assert out.strip() == ("[False, False, False] [{'OPENBLAS_NUM_THREADS': '2'}, {'OMP_NUM_THREADS': '3'}, "
                           "{'GOTO_NUM_THREADS': '2'}]")


def test_command_line_import_does_not_load_numpy():
    """cli.main calls one_thread_from_start before anything imports numpy: the import of
    the command line module (and its parser) must not load it."""
    code = ("import sys; import gcode_opt.cli as c; c.build_parser().parse_args(['process', 'x.gcode']); "
            "print('numpy' in sys.modules)")
    out = subprocess.run([sys.executable, "-c", code], capture_output=True, text=True, check=True).stdout
    assert out.strip() == "False"


def test_command_runs_with_openblas_on_one_thread(tmp_path):
    """In a real run the variable is set before numpy loads, so OpenBLAS reports one thread
    outside the job's own blas_one_thread block too (checked after the command returns)."""
    import os
    sample = os.path.join(os.path.dirname(__file__), "..", "sample_gcode", "prusa_gyroid.gcode")
    code = ("import os, sys; from gcode_opt import cli, blas; "
            f"rc = cli.main(['process', {sample!r}, '-o', {str(tmp_path / 'o.gcode')!r}, '-q', '--no-ringing']); "
            "fns = blas._openblas_thread_fns(); "
            "print(rc, os.environ.get('OPENBLAS_NUM_THREADS'), fns[0]() if fns else 1)")
    env = {k: v for k, v in os.environ.items() if k not in blas._THREAD_ENV}
    out = subprocess.run([sys.executable, "-c", code], capture_output=True, text=True, check=True, env=env).stdout
    assert out.strip() == "0 1 1"
