"""ana64 harness: analyse a plate on the windowed path, capturing the strokes SpilledInputs plans
(not planning them), then replays the spill's planning on copies of them with callgrind
collecting only the replay, a dump per step (pin: plan_inputs, put: GeomKeep.put, append:
StrokeStore.append).  Run: valgrind --tool=callgrind --collect-atstart=no ... python harness.py FILE"""
import sys, os, ctypes, tempfile, time
lib = ctypes.CDLL('/tmp/crv62_libcgt.so')
os.environ['GCODE_OPT_WINDOWED'] = '1'
import gcode_opt.cli, gcode_opt.pipeline as pl, gcode_opt.plan_windows as pw
from gcode_opt.stroke_store import StrokeStore
from gcode_opt.geom_keep import GeomKeep
from gcode_opt.schedule import plan_inputs
cap = StrokeStore(in_memory=True)
import importlib, functools
stack = ['other']
def wrap(mod, name):
    m = importlib.import_module(mod)
    owner = m
    parts = name.split('.')
    for p_ in parts[:-1]:
        owner = getattr(owner, p_)
    f = owner.__dict__[parts[-1]] if isinstance(owner, type) else getattr(owner, parts[-1])
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
    setattr(owner, parts[-1], w)
for spec in filter(None, os.environ.get('HFUNCS', '').split(',')):
    mod, name = spec.split(':'); wrap(mod, name)
bounds = [0]
def _capture(self):
    sts, self.held = self.held, []
    cap.append(sts)
    bounds.append(len(cap))
pw.SpilledInputs._planned = _capture
ctx = {}
_an = pl._analysed
def _stop(in_path, profile, opts, freeze, timing, store=None):
    got = _an(in_path, profile, opts, freeze, timing, store)
    if store.held:
        store._planned()
    ctx.update(profile=profile, opts=opts, window=store.geoms.window)
    raise SystemExit(0)
pl._analysed = _stop
sys.argv = ['gcode_opt', 'process', sys.argv[1], '-o', '/tmp/ana/h_out.gcode', '-q', '--profile', 'prusa-mk3s']
try:
    gcode_opt.cli.main()
except SystemExit:
    pass
profile, opts, window = ctx['profile'], ctx['opts'], ctx['window']
folder = tempfile.mkdtemp(prefix='ana_h')
gk = GeomKeep(window, profile, folder)
store = StrokeStore(folder=folder)
valgrind = os.environ.get('HARNESS_CG') == '1'
T = {'pin': 0.0, 'put': 0.0, 'append': 0.0}
import gc
gc.disable()
hp = __import__('hashlib').sha256()
reps = int(os.environ.get('HARNESS_REPS', '1'))
for rep in range(reps):
    for a, b in zip(bounds[:-1], bounds[1:]):
        sts = cap.load(a, b)
        lo = len(store)
        if valgrind: lib.cg_toggle()
        stack[:] = ['pin']
        t0 = time.perf_counter()
        pin = plan_inputs(sts, profile, opts, end_cols=True, spilled=True)
        t1 = time.perf_counter()
        if valgrind: lib.cg_dump(b'pin')
        stack[:] = ['put']
        gk.put(lo, sts, pin.plan_kind_codes)
        t2 = time.perf_counter()
        if valgrind: lib.cg_dump(b'put')
        stack[:] = ['append']
        store.append(sts)
        t3 = time.perf_counter()
        if valgrind: lib.cg_dump(b'append'); lib.cg_toggle()
        hp.update(repr(sorted((k, (repr(v.tolist()) if v.dtype == object else v.tobytes()) if hasattr(v, 'tobytes') else (repr(v) if v is None or type(v) in (int, float, str, bool, dict) else type(v).__name__)) for k, v in vars(pin).items())).encode())
        T['pin'] += t1 - t0; T['put'] += t2 - t1; T['append'] += t3 - t2
        del sts, pin
print('batches', len(bounds) - 1, 'strokes', bounds[-1], {k: round(v / reps, 4) for k, v in T.items()})
# a digest of what was made (to compare variants): the store's record bytes and the kept geometry's file bytes
import hashlib
h = hashlib.sha256()
buf = bytearray(store._end); store._io.read_into(memoryview(buf), 0) if hasattr(store._io, 'read_into') else None
h.update(bytes(buf))
import gcode_opt.stroke_store as _ss
_n = len(store)
for _io, _nb in ((store._side_io, 8 * len(_ss.SIDE) * _n), (store._fvals_io, 8 * len(_ss.FIELDS_SIDE) * _n), (store._fkinds_io, len(_ss.FIELDS_SIDE) * _n)):
    _b = bytearray(_nb); _io.read_into(memoryview(_b), 0); h.update(bytes(_b))
print('sides', __import__('hashlib').sha256(bytes(_b)).hexdigest()[:8], sorted(store._side_off))
print('store', __import__('hashlib').sha256(bytes(buf)).hexdigest()[:12], 'n', store._end)
print('gk doubles', gk.end, 'recs', sum(len(v) for v in gk.recs.values()))
print('digest', h.hexdigest()[:16], 'pin', hp.hexdigest()[:16])
os._exit(0)
