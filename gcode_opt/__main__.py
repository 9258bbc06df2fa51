import sys
from .cli import exit_process, main
code = main()
if sys.modules["__main__"].__dict__ is globals():      # (the process's main module: python -m gcode_opt)
    exit_process(code)
sys.exit(code)
