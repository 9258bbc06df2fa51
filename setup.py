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
import hashlib
from pathlib import Path

from setuptools import Extension, setup
from setuptools.command.build_ext import build_ext

UNIX_FLAGS = ["-O2", "-ffp-contract=off", "-fno-fast-math", "-fno-builtin-sin", "-fno-builtin-cos"]
MSVC_FLAGS = ["/O2", "/fp:precise"]


class BuildExt(build_ext):
    def build_extensions(self):
        flags = MSVC_FLAGS if self.compiler.compiler_type == "msvc" else UNIX_FLAGS
        for ext in self.extensions:
            ext.extra_compile_args = list(flags)
        super().build_extensions()


def _sha256(source):
    return hashlib.sha256(Path(__file__).resolve().parent.joinpath(source).read_bytes()).hexdigest()


SOURCE = "gcode_opt/firmware/_core.c"
SHA256 = _sha256(SOURCE)
READER_SOURCE = "gcode_opt/_reader.c"
CHAIN_SOURCE = "gcode_opt/laws/_chaincore.c"   # the chains' Newton steps (laws/chain.py), same rules
EMIT_SOURCE = "gcode_opt/_emit.c"               # the rewrite's emitter and validator passes (emit.py, validate.py)
CURVE_SOURCE = "gcode_opt/laws/_curvecore.c"    # the circle law's iteration and the curves' kernel (circle.py, curves.py)

setup(
    ext_modules=[Extension("_gcode_opt_fwcore", [SOURCE], optional=True,
                           define_macros=[("FWCORE_SOURCE_SHA256", f'"{SHA256}"')]),
                 Extension("_gcode_opt_reader", [READER_SOURCE], optional=True,
                           define_macros=[("READER_SOURCE_SHA256", f'"{_sha256(READER_SOURCE)}"')]),
                 Extension("_gcode_opt_chaincore", [CHAIN_SOURCE], optional=True,
                           define_macros=[("CHAINCORE_SOURCE_SHA256", f'"{_sha256(CHAIN_SOURCE)}"')]),
                 Extension("_gcode_opt_emit", [EMIT_SOURCE], optional=True,
                           define_macros=[("EMIT_SOURCE_SHA256", f'"{_sha256(EMIT_SOURCE)}"')]),
                 Extension("_gcode_opt_curvecore", [CURVE_SOURCE], optional=True,
                           define_macros=[("CURVECORE_SOURCE_SHA256", f'"{_sha256(CURVE_SOURCE)}"')])],
    cmdclass={"build_ext": BuildExt},
)
