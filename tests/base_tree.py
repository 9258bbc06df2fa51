"""A past commit's Python code unpacked beside this tree's compiled cores, for tests that
compare the bytes a changed Python module writes with what the commit's wrote.

The cores are this tree's .so files; the C sources and headers are this tree's too, so that
native.load finds the cores built from the sources beside them.  With the commit's own C
sources a changed core reads as stale and the firmware model falls back to pure Python,
whose ringing figures differ from the compiled ones in the last bits (what a C change
does is checked by its own tests and the reference set, not here)."""
import os
import shutil
import subprocess
from glob import glob

ROOT = os.path.dirname(os.path.dirname(os.path.abspath(__file__)))


def unpack(commit, dest):
    """commit's gcode_opt and profiles (the bundled profiles too: an installed, not editable,
    gcode_opt's are not found from a tree on PYTHONPATH, which looks beside its package)
    unpacked into dest with this tree's cores; False if the commit is not in the history."""
    try:
        arch = subprocess.run(["git", "-C", ROOT, "archive", commit, "gcode_opt", "profiles"], capture_output=True,
                              check=True)
    except (OSError, subprocess.CalledProcessError):
        return False
    subprocess.run(["tar", "-x", "-C", str(dest)], input=arch.stdout, check=True)
    for so in glob(os.path.join(ROOT, "_gcode_opt_*.so")):
        shutil.copy(so, dest)
    src = os.path.join(ROOT, "gcode_opt")
    for path in glob(os.path.join(src, "**", "*.[ch]"), recursive=True):
        shutil.copy2(path, os.path.join(dest, "gcode_opt", os.path.relpath(path, src)))
    return True


def command(tree):
    """The interpreter arguments that run gcode-opt's command line from tree (then its
    arguments): `-m gcode_opt` for a past commit; for this tree, with the report's drawn curve
    law solved to the solver's own tail as the past commits drew it (round 42 draws it at
    report.profiles.PLOT_TAIL_TOL; tests/test_speed56_rep56_spline.py checks that law against
    this one), so that everything else the report writes is compared byte for byte."""
    if os.path.realpath(tree) != os.path.realpath(ROOT):
        return ["-m", "gcode_opt"]
    return ["-c", "import sys\nfrom gcode_opt.laws import curve\nfrom gcode_opt.report import profiles\n"
                  "profiles.PLOT_TAIL_TOL = curve._TAIL_TOL\nfrom gcode_opt.cli import main\nsys.exit(main())\n"]
