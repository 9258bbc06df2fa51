"""Run a benchmark script with the chains' batch sizes set from the environment (memo53's
measurements of the trade-off between a windowed candidates' calls and its peak):
MEMO53_CHAIN_BATCH -> schedule.CHAIN_BATCH, MEMO53_SOLVE_CHUNK -> chains.SOLVE_CHUNK (and
chains.SOLVE_SEGS = 20 x it).

    PYTHONPATH=TREE python benchmarks/memo53/with_sizes.py SCRIPT ARGS..."""
import os
import runpy
import sys

from gcode_opt import chains, schedule

if os.environ.get("MEMO53_CHAIN_BATCH"):
    schedule.CHAIN_BATCH = int(os.environ["MEMO53_CHAIN_BATCH"])
if os.environ.get("MEMO53_SOLVE_CHUNK"):
    chains.SOLVE_CHUNK = int(os.environ["MEMO53_SOLVE_CHUNK"])
    chains.SOLVE_SEGS = 20 * chains.SOLVE_CHUNK
sys.argv = sys.argv[1:]
runpy.run_path(sys.argv[0], run_name="__main__")
