"""Build and load C code with the machine's C compiler: the native backend of generated solvers.

Why a C compiler at all: the speed goals of the generated solvers (tens of microseconds for one pose,
several hundred thousand poses a second in batches) are out of reach of CPython's ~50 ns per float
operation (measured: ``benchmarks/results/compiler.md``).  No Python package is added for it: the
generated module carries its chain as C source, this module compiles it once with ``cc`` into a
shared library cached on disk (keyed by a hash of the source and the compiler) and loads it with
``ctypes`` from the standard library.  Without a compiler, or with ``IKC_NATIVE=0`` in the
environment, :func:`load` returns None and the module runs its pure-Python fast path: the same
arithmetic, the same answers, slower.

The code shared by every generated chain lives beside this file: ``fast_kernels.h``, a C port of the
kernels of :mod:`subproblems.fast` that keeps their operation order (so the two backends agree to
rounding), and ``fast_finish.h``, the port of its ``finish_one`` and a threaded driver over N poses.
The finish is compiled once per machine into its own cached shared library and each chain alone
against it (:func:`build`; docs/design.md, section 14): a new robot costs only its chain's build.

Settings (environment): ``IKC_NATIVE=0`` disables the native backend; ``IKC_CACHE`` names the cache
directory (default ``$XDG_CACHE_HOME/ikcompiler`` or ``~/.cache/ikcompiler``); ``CC`` the compiler;
``IKC_SIMD=0`` leaves out the processor's flags (:func:`machine_flags`).
"""

from __future__ import annotations

import ctypes
import functools
import hashlib
import os
import platform
import re
import shutil
import subprocess
import tempfile
from pathlib import Path

# -ffp-contract=off: no fused multiply-adds, so C rounds like the Python path; -fno-math-errno lets
# sqrt inline (errno is never read).  No -ffast-math: NaN and infinity checks must keep working.
# -O3: 2-4% fewer instructions in the finish, the same bits (docs/design.md section 14, "Compiler
# flags"); the finish is compiled once per machine, so its compile time does not count.
FLAGS = ("-O3", "-std=c99", "-ffp-contract=off", "-fno-math-errno", "-fPIC", "-shared", "-pthread")
# A chain alone, against the shared finish (split build, below), without the second (post register
# allocation) instruction scheduling: 10% of the compiler's instructions on puma560's chain, no
# measured cost in batch time on this out-of-order CPU, the same bits (docs/design.md section 14).
CHAIN_FLAGS = ("-O2",) + FLAGS[1:] + ("-fno-schedule-insns2",)
# A function of a chain that runs rarely (the plan's alternative chain: only where the chain cannot
# settle a target) is declared COLD: GCC compiles it at -O1 and as cold code, 7% of the compiler's
# instructions on puma560's chain (docs/design.md section 14).  The rounding is the same at every -O
# level (no -ffast-math, no contraction), so are the answers; other compilers ignore the macro.
COLD = "IKC_COLD"
COLD_DEFINITION = (
    "#ifndef IKC_COLD\n#if defined(__GNUC__) && !defined(__clang__)\n"
    '#define IKC_COLD __attribute__((optimize("O1"), cold))\n#else\n#define IKC_COLD\n#endif\n#endif')

last_error: str | None = None  # why the last load returned None (for `ikc compile` to report)
_loaded: dict[str, ctypes.CDLL] = {}


# beside this file, put in front of every chain
HEADERS = ("fast_kernels.h", "fast_finish.h", "general6.h", "free_ends.h")


def kernels_source() -> str:
    """The C every generated chain includes: the kernels, then the finish and the driver."""
    return "\n".join(Path(__file__).with_name(name).read_text() for name in HEADERS)


def enabled() -> bool:
    return os.environ.get("IKC_NATIVE", "1").strip().lower() not in ("0", "false", "no", "off")


def compiler() -> str | None:
    """The C compiler to use: ``$CC`` or the first of cc, gcc, clang on the PATH."""
    cc = os.environ.get("CC")
    if cc:
        return shutil.which(cc.split()[0]) and cc
    for name in ("cc", "gcc", "clang"):
        if shutil.which(name):
            return name
    return None


def cache_dir() -> Path:
    env = os.environ.get("IKC_CACHE")
    if env:
        return Path(env)
    base = os.environ.get("XDG_CACHE_HOME") or os.path.join(os.path.expanduser("~"), ".cache")
    return Path(base) / "ikcompiler"


def machine_flags() -> tuple[str, ...]:
    """Flags for this machine's processor, added to every build (and so to every cache key: a library
    built with them is never found by a machine without them): ``-mavx2`` on an x86-64 processor with
    AVX2 (read from /proc/cpuinfo; elsewhere none).  AVX2 without FMA changes no rounding (each vector
    lane is the scalar IEEE operation, and -ffp-contract=off forbids contraction): the same bits, with
    the arithmetic of a chain in 3-operand and 4-wide instructions (docs/design.md section 14,
    "Compiler flags").  ``IKC_SIMD=0`` in the environment leaves them out."""
    if os.environ.get("IKC_SIMD", "1").strip().lower() in ("0", "false", "no", "off"):
        return ()
    return _cpu_flags()


@functools.lru_cache(maxsize=1)
def _cpu_flags() -> tuple[str, ...]:
    if platform.machine().lower() not in ("x86_64", "amd64"):
        return ()
    try:
        with open("/proc/cpuinfo") as f:
            for line in f:
                if line.startswith("flags"):
                    return ("-mavx2",) if "avx2" in line.split() else ()
    except OSError:
        pass
    return ()


@functools.lru_cache(maxsize=8)
def _compiler_id(cc: str) -> str:
    """The compiler's first ``--version`` line (part of every cache key); asked once per process."""
    try:
        out = subprocess.run(cc.split() + ["--version"], capture_output=True, text=True, timeout=30)
        return out.stdout.splitlines()[0] if out.stdout else cc
    except (OSError, subprocess.SubprocessError):
        return cc


def _cache_directory() -> Path:
    directory = cache_dir()
    try:
        directory.mkdir(parents=True, exist_ok=True)
    except OSError:
        directory = Path(tempfile.gettempdir()) / "ikcompiler-cache"
        directory.mkdir(parents=True, exist_ok=True)
    return directory


def replace_atomically(target: Path, fill) -> None:
    """Write ``target`` through a partial file beside it (``fill(partial)`` writes that), then rename:
    atomic on one file system, so another process writing the same cache file at the same time leaves
    one whole file and nobody reads a half-written one.  OSError passes to the caller."""
    partial = target.with_name(f".{target.name}.{os.getpid()}")
    fill(partial)
    os.replace(partial, target)


def _compile(cc: str, flags, text: str, target: Path, extra=(), prelude: str = "") -> bool:
    """Compile ``prelude + text`` into the shared library ``target`` (kept when it exists); False with
    :data:`last_error` set when the compiler fails.  A ``prelude`` (the headers in front of a chain)
    is read from its precompiled form where the compiler made one (:func:`_precompiled`): the same
    code, without parsing the headers again; where that compile fails, the whole text is compiled."""
    global last_error
    if target.exists():
        return True
    header = _precompiled(cc, flags, prelude) if prelude else None
    with tempfile.TemporaryDirectory(prefix="ikc-build-") as tmp:
        src = Path(tmp) / "chain.c"
        lib = Path(tmp) / "chain.so"
        done = None
        if header is not None:
            src.write_text(text)
            done = _run(cc, [*flags, "-include", str(header), "-o", str(lib), str(src), *extra, "-lm"])
        if done is None or done.returncode != 0:
            src.write_text(prelude + text)
            done = _run(cc, [*flags, "-o", str(lib), str(src), *extra, "-lm"])
        if isinstance(done, str):
            last_error = done
            return False
        if done.returncode != 0:
            last_error = f"{cc} failed: {done.stderr.strip()[:2000]}"
            return False
        # another process may build the same library at the same time
        try:
            replace_atomically(target, lambda partial: shutil.copyfile(lib, partial))
        except OSError as exc:
            last_error = (f"cannot write the C build to {target.parent} ({exc}); "
                          "set IKC_CACHE to a writable one")
            return False
    return True


def _run(cc: str, args):
    """The finished compiler process, or a message (str) when it could not run."""
    try:
        return subprocess.run(cc.split() + list(args), capture_output=True, text=True, timeout=300)
    except (OSError, subprocess.SubprocessError) as exc:
        return f"{cc} failed to run: {exc}"


def _precompiled(cc: str, flags, prelude: str) -> Path | None:
    """The cached header ``ikc_prelude_<key>.h`` with its precompiled form ``.h.gch`` beside it (built
    on first use, once per machine: key the header text, the compiler, the flags), or None where the
    compiler cannot make one.  ``-include`` of the header then reads the .gch (GCC checks that it fits
    the compile's flags and falls back to the header's text where it does not: the same code either
    way; docs/design.md section 14)."""
    pch_flags = [f for f in flags if f != "-shared"]
    try:
        directory = _cache_directory()
    except OSError:
        return None
    header = directory / f"ikc_prelude_{_key(prelude, _compiler_id(cc), ' '.join(pch_flags))}.h"
    gch = header.with_name(header.name + ".gch")
    if header.exists() and gch.exists():
        return header
    with tempfile.TemporaryDirectory(prefix="ikc-pch-") as tmp:
        text, out = Path(tmp) / "prelude.h", Path(tmp) / "prelude.h.gch"
        text.write_text(prelude)
        done = _run(cc, [*pch_flags, "-x", "c-header", "-o", str(out), str(text)])
        if isinstance(done, str) or done.returncode != 0 or not out.exists():
            return None
        try:  # the text first: a process finding both finds the .gch whole
            replace_atomically(header, lambda partial: partial.write_text(prelude))
            replace_atomically(gch, lambda partial: shutil.copyfile(out, partial))
        except OSError:
            return None
    return header


def _key(*parts: str) -> str:
    return hashlib.sha256("\0".join(parts).encode()).hexdigest()[:20]


# The split build (docs/design.md, section 14): the finish is the same for every chain, so it is
# compiled once per machine (per header text, compiler and flags) into a shared library that exports
# its entry points under SHARED names (aliases of the header's static functions); a chain is then
# compiled alone, with the kernels (static inline: they must inline into the chain) and the header's
# declarations in front, and its entry points' calls renamed to the shared ones.  `__typeof__` takes
# each signature from the header itself, so the two sides cannot disagree.  The finish calls the
# chain through `ikc_robot.chain` (a pointer) either way: nothing is lost across the library edge.
FINISH_ENTRIES = ("ikc_one", "ikc_one_exact", "ikc_many", "ikc_last_reason", "ikc_g6_leaves",
                  "ikc_many_block", "ikc_free_one", "ikc_free_many")  # chains call
# (ikc_last_reason: why this thread's last target was handed back, for the benchmarks' cause counts;
# ikc_g6_leaves: the general-6r elimination of general6.h, docs/general6.md "Native path"; ikc_free_one,
# ikc_free_many: free_ends.h, a general-6r module's free end joints, runtime/freeends.py)
SHARED_PREFIX = "ikc_shared_"


# Kernels a chain calls from the shared finish library instead of compiling its own copy (the split
# build): GCC inlines none of their call sites in a chain (several sites each, bodies too large), so a
# chain's copies were out-of-line code compiled once per chain (~110 M compiler instructions of ur5's
# ~1.2 G).  The library's copies are the same C, so the same operations and bits (no -ffast-math,
# no contraction at any -O level); a call goes through the PLT instead of a local call.
OUT_OF_LINE_KERNELS = ("ikc_angle_about_cs", "ikc_trig_roots_cs")
KERNEL_MARK = "\n * the kernels */\n"  # fast_kernels.h: the subproblem kernels after this line
SHARED_KERNELS_MACRO = "IKC_SHARED_KERNELS"  # defined by the split build's chain prelude


def _shared_name(name: str) -> str:
    return SHARED_PREFIX + "k_" + name[4:]


@functools.lru_cache(maxsize=4)
def shared_kernels(text: str | None = None) -> tuple[str, ...]:
    """The kernels the finish library exports for the chains: the subproblem kernels of
    ``fast_kernels.h`` (which a cold chain calls there rather than compile them: docs/design.md
    section 14) and :data:`OUT_OF_LINE_KERNELS` (which every chain calls there)."""
    text = text if text is not None else Path(__file__).with_name(HEADERS[0]).read_text()
    names = re.findall(r"^static inline [^(]*?\b(ikc_\w+)\(", text.split(KERNEL_MARK, 1)[-1], re.M)
    return tuple(dict.fromkeys([*OUT_OF_LINE_KERNELS, *names]))


def cold_kernel_renames(text: str) -> list[str]:
    """C lines that make the cold code after them (``text``: its C) call the finish library's copies
    of the kernels it calls, in the split build (its prelude defines :data:`SHARED_KERNELS_MACRO`); the
    one-piece build keeps its own.  A cold chain needs no inlining, so compiling the kernels into it
    was a third of puma560's chain build (docs/design.md section 14)."""
    called = set(re.findall(r"\b(ikc_\w+)\(", text))
    lines = [f"#define {name} {_shared_name(name)}" for name in shared_kernels()
             if name in called and name not in OUT_OF_LINE_KERNELS]
    return [f"#ifdef {SHARED_KERNELS_MACRO}", *lines, "#endif"] if lines else []


def _declaration_only(text: str, name: str) -> str:
    """``text`` (a header) with the static inline definition of ``name`` made a plain declaration (its
    body runs from the signature's brace to the first line that is ``}``)."""
    m = re.search(r"^static inline ([^(]*?\b" + name + r"\([^)]*\))\s*\{", text, re.M)
    if m is None:
        raise ValueError(f"no definition of {name} in the kernels")
    end = text.index("\n}\n", m.end()) + 3
    return text[:m.start()] + m.group(1) + ";\n" + text[end:]


def _finish_library_source() -> str:
    aliases = [f'__typeof__({name}) {SHARED_PREFIX}{name[4:]} __attribute__((alias("{name}")));'
               for name in FINISH_ENTRIES]
    aliases += [f'__typeof__({name}) {_shared_name(name)} __attribute__((alias("{name}")));'
                for name in shared_kernels()]
    head = "\n/* exported for the chains (subproblems/native.py) */\n"
    return kernels_source() + head + "\n".join(aliases) + "\n"


def _chain_kernels_source() -> str:
    """The kernels and finish as a chain of the split build sees them: the out-of-line kernels
    declared only (their calls, inlined kernels' too, renamed to the library's copies)."""
    renames = [f"#define {name} {_shared_name(name)}" for name in OUT_OF_LINE_KERNELS]
    text = kernels_source()
    for name in OUT_OF_LINE_KERNELS:
        text = _declaration_only(text, name)
    return "\n".join(renames) + "\n" + text


def _chain_prelude() -> str:
    lines = ["/* the finish is in a shared library (subproblems/native.py): its entry points by name */"]
    for name in FINISH_ENTRIES:
        lines.append(f"extern __typeof__({name}) {SHARED_PREFIX}{name[4:]};")
        lines.append(f"#define {name} {SHARED_PREFIX}{name[4:]}")
    lines.append("/* and its kernels, for cold code (native.cold_kernel_renames) */")
    lines += [f"extern __typeof__({name}) {_shared_name(name)};" for name in shared_kernels()
              if name not in OUT_OF_LINE_KERNELS]
    lines.append(f"#define {SHARED_KERNELS_MACRO} 1")
    return _chain_kernels_source() + "\n" + "\n".join(lines) + "\n"


def _finish_library(cc: str, cc_id: str, directory: Path, machine: tuple[str, ...] = ()) -> Path | None:
    """The cached shared finish library (built on first use), or None when the split build fails."""
    text = _finish_library_source()
    flags = FLAGS + machine
    target = directory / f"ikc_finish_{_key(text, cc_id, ' '.join(flags))}.so"
    return target if _compile(cc, flags, text, target) else None


def build(source: str, *, include_kernels: bool = True) -> Path | None:
    """Compile ``source`` (with the kernels in front) into a cached shared library; its path or None.

    With the kernels, the chain is built alone against the shared finish library (compiled once);
    where that split build fails (a compiler without ``__typeof__`` or symbol aliases) the whole text
    is compiled in one piece, as before.  Every build has :func:`machine_flags`; a compiler that
    refuses them builds without."""
    machine = machine_flags()
    path = _build(source, include_kernels, machine)
    if path is None and machine:
        path = _build(source, include_kernels, ())
    return path


def _build(source: str, include_kernels: bool, machine: tuple[str, ...]) -> Path | None:
    global last_error
    cc = compiler()
    if cc is None:
        last_error = "no C compiler found (set CC, or install gcc)"
        return None
    try:
        kernels = kernels_source() if include_kernels else ""
    except OSError as exc:
        last_error = f"the C kernels are missing from the installation: {exc}"
        return None
    cc_id = _compiler_id(cc)
    try:
        directory = _cache_directory()
    except OSError as exc:
        last_error = f"cannot create a cache directory ({exc}); set IKC_CACHE to a writable one"
        return None
    if include_kernels:
        finish = _finish_library(cc, cc_id, directory, machine)
        if finish is not None:
            prelude = _chain_prelude()
            flags = CHAIN_FLAGS + machine
            target = directory / f"ikc_{_key(prelude + source, cc_id, ' '.join(flags), str(finish))}.so"
            if _compile(cc, flags, source, target, extra=(str(finish),), prelude=prelude):
                return target
    text = (kernels + "\n" if include_kernels else "") + source
    flags = FLAGS + machine
    target = directory / f"ikc_{_key(text, cc_id, ' '.join(flags))}.so"
    return target if _compile(cc, flags, text, target) else None


# -- the block chain of a batch (docs/design.md section 14, "SIMD over poses") ---------------------------
LANE_HEADER = "lane_kernels.h"  # beside this file, put in front of a block chain (after the kernels)


def block_enabled() -> bool:
    """Whether batches run the block chain where a module has one (``IKC_BLOCK=0``: the scalar driver
    alone, read at each batch; the tests compare the two)."""
    return os.environ.get("IKC_BLOCK", "1").strip().lower() not in ("0", "false", "no", "off")


def libmvec_enabled() -> bool:
    """Whether a block chain takes its angles from glibc's libmvec (AVX2 atan2 and acos, 4 lanes a
    call; a few ulps from libm's): on an AVX2 build unless ``IKC_LIBMVEC=0``."""
    return os.environ.get("IKC_LIBMVEC", "1").strip().lower() not in ("0", "false", "no", "off")


def build_block(source: str) -> Path | None:
    """Compile a block chain (``csource.block_c_source``) against the shared finish, with the kernels,
    the finish's declarations and the lane kernels in front; its path, or None (no split build, no
    compiler).  With libmvec where the build can link it (else libm's angles, lane by lane)."""
    global last_error
    cc = compiler()
    if cc is None or not enabled():
        last_error = "no C compiler found (set CC, or install gcc)" if cc is None else "disabled by IKC_NATIVE=0"
        return None
    machine = machine_flags()
    try:
        lane = Path(__file__).with_name(LANE_HEADER).read_text()
        directory = _cache_directory()
    except OSError as exc:
        last_error = f"the lane kernels or the cache directory are missing: {exc}"
        return None
    cc_id = _compiler_id(cc)
    finish = _finish_library(cc, cc_id, directory, machine)
    if finish is None:
        return None
    prelude = _chain_prelude() + lane + "\n"
    variants = [((), ())]
    if "-mavx2" in machine and libmvec_enabled():
        variants.insert(0, (("-DIKC_LIBMVEC",), ("-lmvec",)))
    for defines, libs in variants:
        flags = CHAIN_FLAGS + machine + defines
        target = directory / f"ikc_block_{_key(prelude + source, cc_id, ' '.join(flags), str(finish))}.so"
        if _compile(cc, flags, source, target, extra=(str(finish),) + libs, prelude=prelude):
            return target
    return None


def load(source: str) -> ctypes.CDLL | None:
    """The shared library of ``source``, built on first use; None when disabled or it cannot build."""
    global last_error
    if not enabled():
        last_error = "disabled by IKC_NATIVE=0"
        return None
    if source in _loaded:
        return _loaded[source]
    path = build(source)
    if path is None:
        return None
    try:
        lib = ctypes.CDLL(str(path))
    except OSError as exc:
        last_error = f"cannot load {path}: {exc}"
        return None
    last_error = None
    _loaded[source] = lib
    return lib


def threads() -> int:
    """Worker threads for batches: ``IKC_THREADS``, else the cores this process may use (at most 8)."""
    env = os.environ.get("IKC_THREADS")
    if env and env.strip().isdigit():
        return max(1, int(env))
    try:
        cores = len(os.sched_getaffinity(0))
    except AttributeError:
        cores = os.cpu_count() or 1
    return max(1, min(cores, 8))


_TARGET_SHAPES = {"pose": (4, 4), "position": (3,), "orientation": (3, 3)}
PYTHON, INVALID = -1, -2  # codes of NativeChain.many besides a solution count


class NativeChain:
    """The compiled chain of one generated module (the entry points of ``csource.chain_c_source``).

    :meth:`one` solves one raw target (None: take the Python path); :meth:`many` solves N checked
    targets and says, per target, whether the Python path must take it over.
    """

    def __init__(self, lib: ctypes.CDLL, *, dof: int, slots: int, nfree: int, target: str):
        import threading

        import numpy as np

        self._np = np
        self._lib = lib
        self.dof, self.slots, self.nfree = dof, slots, nfree
        # the block chain (bind_block, on the first batch): its ikc_solve_many_block and our ikc_robot
        self._block, self._block_lib, self._robot_data, self._block_tried = None, None, None, False
        self.block_build_ms = None  # what printing and building the block chain took (None: not tried)
        P, I, L = ctypes.c_void_p, ctypes.c_int, ctypes.c_int64  # noqa: E741
        self._one = lib.ikc_solve_one
        self._one.argtypes = [P, P, I, P, P, P, P]
        self._one.restype = I
        self._many = lib.ikc_solve_many
        self._many.argtypes = [L, P, P, I, P, P, P, P, P, I]
        self._many.restype = None
        self._exact = lib.ikc_solve_exact
        self._exact.argtypes = [P, P, I, P]
        self._exact.restype = I
        self.leaves_fn = lib.ikc_leaves
        self.leaves_fn.argtypes = [P, P, P, P, P]
        self.leaves_fn.restype = I
        # why the last target handed back was (fast_finish.h IKC_WHY_*; the split build only)
        self._reason = getattr(lib, SHARED_PREFIX + "last_reason", None)
        if self._reason is not None:
            self._reason.argtypes, self._reason.restype = [], I
        # one target: buffers reused under a lock (the call and the copies out are one critical section)
        self._lock = threading.Lock()
        self.target_shape = _TARGET_SHAPES[target]  # one raw target: (4, 4), (3, 3) or (3,)
        self._T = np.zeros(self.target_shape)
        self._F = np.zeros(max(nfree, 1))
        self._q = np.zeros((slots, dof))
        self._res = np.zeros(slots)
        self._ls = np.zeros(slots, dtype=np.intc)
        self._cont = np.zeros(slots, dtype=np.intc)
        self._addr = [a.ctypes.data for a in (self._T, self._F, self._q, self._res, self._ls, self._cont)]

    def _staged(self, T, free) -> bool:
        """Copy one target and its free values into the buffers (the caller holds the lock).  False
        unless they are exactly the target's shape and one value per free joint: anything else (which
        numpy would broadcast into the buffers) goes the Python way, which raises the documented error."""
        if len(free) != self.nfree or self._np.shape(T) != self._T.shape:
            return False
        try:
            self._T[...] = T
            if self.nfree:
                self._F[...] = free
        except (ValueError, TypeError):
            return False
        return True

    def one(self, T, free, limits: bool):
        """``(q, residual, ls, continuum)`` of one target, or None for the Python path."""
        with self._lock:
            if not self._staged(T, free):
                return None
            aT, aF, aq, ares, als, acont = self._addr
            k = self._one(aT, aF, 1 if limits else 0, aq, ares, als, acont)
            if k < 0:
                return None
            return self._q[:k].copy(), self._res[:k].copy(), self._ls[:k] != 0, self._cont[:k] != 0

    def exact(self, T, free, limits: bool):
        """The exact solutions (k, dof) of one target, or None for the Python path (``solve``)."""
        with self._lock:
            if not self._staged(T, free):
                return None
            aT, aF, aq = self._addr[:3]
            k = self._exact(aT, aF, 1 if limits else 0, aq)
            return None if k < 0 else self._q[:k].copy()

    def last_reason(self) -> int | None:
        """Why this thread's last target was handed back (fast_finish.h ``IKC_WHY_*``: main chain plus
        16 times the alternative chain's; 0 when settled), or None without the split build."""
        return None if self._reason is None else int(self._reason())

    def bind_block(self, source_fn) -> bool:
        """Build and load the block chain on first use (``source_fn()``: its C, or None where the chain
        has none; docs/design.md section 14, "SIMD over poses"); whether :meth:`many` has it.  Tried
        once: a chain without one (or a failed build) keeps the scalar driver."""
        with self._lock:
            if not self._block_tried:
                self._block_tried = True
                import time

                start = time.perf_counter()
                self._bind_block(source_fn)
                self.block_build_ms = 1e3 * (time.perf_counter() - start)
            return self._block is not None

    def _bind_block(self, source_fn) -> None:
        data = getattr(self._lib, "ikc_robot_data", None)
        source = source_fn() if data is not None else None
        path = build_block(source) if source is not None else None
        if path is None:
            return
        try:
            lib = ctypes.CDLL(str(path))
        except OSError:
            return
        P, I, L = ctypes.c_void_p, ctypes.c_int, ctypes.c_int64  # noqa: E741
        data.argtypes, data.restype = [], P
        fn = lib.ikc_solve_many_block
        fn.argtypes = [P, L, P, P, I, P, P, P, P, P, I]
        fn.restype = None
        self._robot_data, self._block_lib, self._block = data(), lib, fn

    def many(self, goals, free, limits: bool, workers: int | None = None):
        """Solutions of N raw targets ``goals`` ((N, 4, 4) poses, (N, 3, 3) orientations or (N, 3)
        positions, as :meth:`one` takes them) with free values ``free`` (N, nfree).

        Returns ``(Q, valid, ls, residual, continuum)`` as the module's batch path packs them, and
        ``code (N,)``: the solution count, :data:`PYTHON` for targets the Python path must take over,
        :data:`INVALID` for targets that are not finite rigid transforms (rows empty for both)."""
        np = self._np
        goals = np.ascontiguousarray(goals, dtype=float)
        N = len(goals)
        free = np.ascontiguousarray(np.broadcast_to(free, (N, self.nfree)), dtype=float)
        Q = np.zeros((N, self.slots, self.dof))
        res = np.full((N, self.slots), np.inf)
        ls = np.zeros((N, self.slots), dtype=np.intc)
        cont = np.zeros((N, self.slots), dtype=np.intc)
        count = np.zeros(N, dtype=np.intc)
        args = (N, goals.ctypes.data, free.ctypes.data, 1 if limits else 0, Q.ctypes.data, res.ctypes.data,
                ls.ctypes.data, cont.ctypes.data, count.ctypes.data, workers or threads())
        if self._block is not None and block_enabled():
            self._block(self._robot_data, *args)
        else:
            self._many(*args)
        valid = np.arange(self.slots)[None, :] < count[:, None]
        res[~valid] = np.inf
        Q[~valid] = 0.0
        return (Q, valid, (ls != 0) & valid, res, (cont != 0) & valid), count


def bind(source: str, *, dof: int, slots: int, nfree: int, target: str) -> NativeChain | None:
    """The compiled chain of a generated module, or None (no compiler, disabled, build failed)."""
    lib = load(source)
    if lib is None:
        return None
    return NativeChain(lib, dof=dof, slots=slots, nfree=nfree, target=target)
