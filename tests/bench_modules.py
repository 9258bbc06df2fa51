"""A benchmarks/ script loaded as a module (benchmarks/ is not a package), for the tests of
its helpers."""
import importlib.util
import os

BENCH = os.path.join(os.path.dirname(os.path.abspath(__file__)), "..", "benchmarks")


def load_bench(name):
    """benchmarks/<name>.py, executed as a fresh module (its __main__ block not run)."""
    spec = importlib.util.spec_from_file_location(name, os.path.join(BENCH, name + ".py"))
    mod = importlib.util.module_from_spec(spec)
    spec.loader.exec_module(mod)
    return mod
