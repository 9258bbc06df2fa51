"""The command line turns numpy's 2 MiB-page advice off (malloc_policy.small_pages, issue 8,
s58): it must take effect in the command's process, stay off when the user set numpy's own
variable or asked for the default allocator policy, and change no byte of the output (the
policy against GCODE_OPT_MALLOC=default, which leaves numpy's advice on, is
test_speed23_group_malloc's comparison)."""
import os
import subprocess
import sys

from gcode_opt import malloc_policy

SAMPLE = os.path.join("sample_gcode", "prusa_gyroid.gcode")

# the command run in a fresh interpreter, then numpy's advice as the run left it
_RUN = """
import sys
from gcode_opt.cli import main
try:
    main(["process", sys.argv[1], "-o", sys.argv[2], "-q", "--profile", "prusa-mk3s"])
except SystemExit as e:
    assert not e.code, e.code
import numpy
print(numpy._core.multiarray._get_madvise_hugepage())
"""


def _env(**kw):
    env = {k: v for k, v in os.environ.items() if k not in ("NUMPY_MADVISE_HUGEPAGE", "GCODE_OPT_MALLOC")}
    env["PYTHONPATH"] = os.getcwd()
    env.update(kw)
    return env


def _advice_after_run(tmp_path, **kw):
    out = subprocess.run([sys.executable, "-c", _RUN, SAMPLE, str(tmp_path / "out.gcode")], env=_env(**kw),
                         capture_output=True, text=True, check=True)
    return out.stdout.split()[-1]


def test_command_runs_without_numpy_huge_pages(tmp_path):
    assert _advice_after_run(tmp_path) == "False"


def test_users_setting_and_default_policy_are_kept(tmp_path):
    assert _advice_after_run(tmp_path, NUMPY_MADVISE_HUGEPAGE="1") == "True"
    assert _advice_after_run(tmp_path, GCODE_OPT_MALLOC="default") == "True"


def test_set_only_before_numpy_and_when_unset():
    # this process has numpy loaded: too late, nothing set
    env = {}
    assert malloc_policy.small_pages(env) is False and env == {}
    probe = ("from gcode_opt import malloc_policy as m\n"
             "e = {}\nprint(m.small_pages(e), e.get('NUMPY_MADVISE_HUGEPAGE'))\n"
             "e = {'NUMPY_MADVISE_HUGEPAGE': '1'}\nprint(m.small_pages(e), e['NUMPY_MADVISE_HUGEPAGE'])\n"
             "e = {'GCODE_OPT_MALLOC': 'default'}\nprint(m.small_pages(e), 'NUMPY_MADVISE_HUGEPAGE' in e)\n")
    got = subprocess.run([sys.executable, "-c", probe], env=_env(), capture_output=True, text=True,
                         check=True).stdout.split("\n")
    assert got[:3] == ["True 0", "False 1", "False False"]
