"""(benchmarks/crv62) Self-cost instruction counts per named function (nested: innermost gets it), by callgrind dumps.
Env CRV_FUNCS: comma list module:function."""
import sys, os, ctypes, functools, importlib
lib = ctypes.CDLL('/tmp/crv62_libcgt.so')
stack = ['other']
def wrap(mod, name):
    m = importlib.import_module(mod)
    f = getattr(m, name)
    label = name.encode()
    @functools.wraps(f)
    def w(*a, **k):
        lib.cg_dump(stack[-1].encode())
        stack.append(name)
        try:
            return f(*a, **k)
        finally:
            lib.cg_dump(label)
            stack.pop()
    setattr(m, name, w)
import gcode_opt.curves
for spec in os.environ['CRV_FUNCS'].split(','):
    mod, name = spec.split(':'); wrap(mod, name)
import gcode_opt.cli, gcode_opt.schedule, gcode_opt.pipeline
sys.argv = ['gcode_opt'] + sys.argv[1:]
gcode_opt.cli.main()
lib.cg_dump(b'other')
