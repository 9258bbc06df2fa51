"""Build the optional compiled core of the firmware model (gcode_opt/firmware/_core.c)
and the compiled fast path of the reader (gcode_opt/_reader.c, module _gcode_opt_reader,
used by state.py under the same rules: optional, top-level, SHA-256 checked, same bits),
and the chains' Newton steps (gcode_opt/laws/_chaincore.c, module _gcode_opt_chaincore,
used by laws/chain.py under the same rules), and the rewrite's per-line work
(gcode_opt/_emit.c, module _gcode_opt_emit, used by emit.py and validate.py, same rules),
and the circle law's iteration and the curves' kernel (gcode_opt/laws/_curvecore.c, module
_gcode_opt_curvecore, used by laws/circle.py and curves.py, same rules).

Everything else is in pyproject.toml.  The extension is optional: without a C compiler
(or Python headers) the build prints a warning, skips it, and the install goes on; the
package then runs its pure-Python model (simulate.CORE == "python").

It is a top-level module, _gcode_opt_fwcore, not one inside the package: a source tree
that shadows the installed package (python -m pytest from the checkout, as CI runs it)
still finds the installed core.  The build records the SHA-256 of the C source it was
made from; simulate.py does not use a core built from another _core.c than the one
beside it (a stale build).

The core must give the same bits as the Python model, so every double operation has to
be the one Python does: no fused multiply-add (-ffp-contract=off; gcc contracts by
default on arm64), no -ffast-math, and sin/cos called as the separate libm functions
Python's math module calls (-fno-builtin-sin/cos: gcc would merge them into sincos)."""
import importlib.util
from pathlib import Path

from setuptools import Extension, setup
from setuptools.command.build_ext import build_ext

UNIX_FLAGS = ["-O2", "-ffp-contract=off", "-fno-fast-math", "-fno-builtin-sin", "-fno-builtin-cos"]
# built at -O3 (after -O2: the last -O wins): its inlining of the firmware core's stops and the
# emit core's number texts saved ~20 M instructions a plate's command (callgrind, windowed:
# rectilinear and gyroid); the reader's parse loops were ~6 M slower so, and stay at -O2.
# -O3 changes no double's bits: the operations are the same ones, -ffp-contract=off and
# -fno-fast-math still hold (no contraction, no reassociation), so its vector loops add no
# reordered sums (benchmarks/fit65.md)
O3_EXTENSIONS = ("_gcode_opt_fwcore", "_gcode_opt_emit")
MSVC_FLAGS = ["/O2", "/fp:precise"]


class BuildExt(build_ext):
    def build_extensions(self):
        flags = MSVC_FLAGS if self.compiler.compiler_type == "msvc" else UNIX_FLAGS
        for ext in self.extensions:
            ext.extra_compile_args = list(flags)
            if ext.name in O3_EXTENSIONS and self.compiler.compiler_type != "msvc":
                ext.extra_compile_args.append("-O3")
            if ext.name == "_gcode_opt_chaincore" and self.compiler.compiler_type != "msvc":
                # sqrt without errno (the chain core reads no errno): its vector loops with
                # a sqrt vectorise; sqrt is correctly rounded either way (the same bits)
                ext.extra_compile_args.append("-fno-math-errno")
            if self.compiler.compiler_type != "msvc":
                # libm named: exp and log bind to its current symbol versions, not the
                # compat wrappers an unnamed libm leaves (~10 instructions a call; the
                # same numbers, and the cores' probes check them against numpy's anyway)
                ext.libraries = list(ext.libraries) + ["m"]
        super().build_extensions()


HERE = Path(__file__).resolve().parent
# gcode_opt/native.py (standard library only) hashes a source with the local headers it
# includes: the same function here and at load time, loaded by path (the package's
# __init__ is not imported at build time)
_spec = importlib.util.spec_from_file_location("_gcode_opt_native_build", HERE / "gcode_opt" / "native.py")
_native = importlib.util.module_from_spec(_spec)
_spec.loader.exec_module(_native)


def _sha256(source):
    return _native.source_digest(str(HERE / source))


def _stat_record(source):
    """The digest and the stat of each file it covers, as hashed (native.stat_record): a
    load finding them unchanged takes the digest without hashing again."""
    return _native.stat_record(str(HERE / source))


def _ext(name, source, macro):
    """An optional extension built from one C source; its local headers are dependencies
    (a changed header rebuilds it) and part of the recorded digest."""
    deps = [str(Path(p).relative_to(HERE)) for p in _native.local_headers(str(HERE / source))]
    return Extension(name, [source], optional=True, depends=deps,
                     define_macros=[(macro, f'"{_sha256(source)}"'),
                                    ("GCODE_OPT_SOURCE_STAT", f'"{_stat_record(source)}"')])


SOURCE = "gcode_opt/firmware/_core.c"
READER_SOURCE = "gcode_opt/_reader.c"
CHAIN_SOURCE = "gcode_opt/laws/_chaincore.c"   # the chains' Newton steps (laws/chain.py), same rules
EMIT_SOURCE = "gcode_opt/_emit.c"               # the rewrite's emitter and validator passes (emit.py, validate.py)
CURVE_SOURCE = "gcode_opt/laws/_curvecore.c"    # the circle law's iteration and the curves' kernel (circle.py, curves.py)

setup(
    ext_modules=[_ext("_gcode_opt_fwcore", SOURCE, "FWCORE_SOURCE_SHA256"),
                 _ext("_gcode_opt_reader", READER_SOURCE, "READER_SOURCE_SHA256"),
                 _ext("_gcode_opt_chaincore", CHAIN_SOURCE, "CHAINCORE_SOURCE_SHA256"),
                 _ext("_gcode_opt_emit", EMIT_SOURCE, "EMIT_SOURCE_SHA256"),
                 _ext("_gcode_opt_curvecore", CURVE_SOURCE, "CURVECORE_SOURCE_SHA256")],
    cmdclass={"build_ext": BuildExt},
)
