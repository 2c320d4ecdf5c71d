"""Compiled kernels: the generated straight-line programs, compiled to machine code by LLVM.

Why: numpy runs the generated programs one operation at a time over whole columns, so a batch
pays numpy's fixed cost (about a microsecond) for each of the hundreds of operations of a
Newton-Euler pass, and a single state pays it in full.  Here each program
(:class:`rworld_cli.codegen.Generated`) becomes one LLVM function: a loop over the samples
with the straight-line body inside, every temporary in a register, nothing allocated.

How:

* **IR.** Each operation of the program is one LLVM instruction (``fadd``, ``fmul``, ``fsub``,
  ``fneg``, ``fdiv``, ``select`` for Coulomb friction, ``llvm.cos/sin/sqrt``), with no
  fast-math flags: IEEE arithmetic in the same order as the numpy fallback, so the results
  agree with it to rounding of cos/sin.  Inputs are arrays with a row stride; stride 0 means
  "the same row for every sample" (gravity).
* **Compile.** llvmlite (LLVM's Python binding, a wheel from PyPI; no compiler on the user's
  machine) optimises at O3 for the host CPU and emits an object file; MCJIT links it into
  the process.  A Newton-Euler kernel of a 6-joint arm compiles in about 40 ms.
* **Cache.** The object file is stored in the cache's ``kernels/`` folder (:mod:`.cache`:
  ``$RWORLD_CACHE_DIR``, a folder only the user can write, entries authenticated by an HMAC
  with the user's secret before the JIT sees them), named by a hash of the IR, the LLVM
  version and the host CPU, so a later process loads it in about a millisecond.  Where the
  folder is refused or not writable the kernel is compiled in memory each time; a corrupt,
  foreign or forged file is recompiled.
* **Threads.** A call runs without the GIL (ctypes releases it), so a batch of at least
  :data:`PARALLEL_MIN` samples is split over the CPUs this process may use
  (``RWORLD_THREADS`` caps it).
* **Off switch.** ``RWORLD_KERNELS=numpy`` (or llvmlite missing, or a failed compile, which
  warns once) falls back to the Python source on numpy columns.

llvmlite is imported on the first kernel call only: commands that need no device physics
never load a compiler.
"""

from __future__ import annotations

import ctypes
import functools
import hashlib
import os
import struct
import threading
import warnings
from concurrent.futures import ThreadPoolExecutor

import numpy as np

KERNEL_FORMAT = 4  # bump when the IR layout changes: old cache files are then never looked up
PARALLEL_MIN = 16384  # samples; below this a second thread costs more than it saves

_LOCK = threading.RLock()
_STATE: dict = {}  # llvmlite module, target machine, engine, keep-alive objects
_POOL: ThreadPoolExecutor | None = None


def backend() -> str:
    """``"llvm"`` when compiled kernels are in use, else ``"numpy"``."""
    choice = os.environ.get("RWORLD_KERNELS", "llvm").strip().lower()
    if choice not in ("llvm", "numpy"):
        raise ValueError(f"RWORLD_KERNELS must be 'llvm' or 'numpy', not {choice!r}")
    if choice == "numpy":
        return "numpy"
    return "llvm" if _llvm() is not None else "numpy"


def thread_count() -> int:
    """How many threads a large batch is split over."""
    try:
        available = len(os.sched_getaffinity(0))
    except AttributeError:  # not Linux
        available = os.cpu_count() or 1
    cap = os.environ.get("RWORLD_THREADS")
    if cap:
        try:
            return max(1, min(available, int(cap)))
        except ValueError:
            raise ValueError(f"RWORLD_THREADS must be a whole number, not {cap!r}") from None
    return max(1, available)


def _llvm():
    """The initialised llvmlite binding and the process's JIT engine, or None."""
    if "llvm" in _STATE:  # set once, never removed: no lock to read it (a hot path asks)
        return _STATE["llvm"]
    with _LOCK:
        if "llvm" in _STATE:
            return _STATE["llvm"]
        try:
            import llvmlite
            import llvmlite.binding as llvm
        except ImportError:
            _STATE["llvm"] = None
            return None
        llvm.initialize_native_target()
        llvm.initialize_native_asmprinter()
        target = llvm.Target.from_default_triple()
        cpu = llvm.get_host_cpu_name()
        features = llvm.get_host_cpu_features().flatten()
        machine = target.create_target_machine(cpu=cpu, features=features, opt=3, jit=True)
        engine = llvm.create_mcjit_compiler(llvm.parse_assembly(""), machine)
        _STATE.update(
            llvm=llvm,
            machine=machine,
            engine=engine,
            keep=[],
            host=f"{llvmlite.__version__}|{llvm.get_default_triple()}|{cpu}|{features}",
        )
        return llvm


# ------------------------------------------------------------------------------------ IR
def _literal(x: float) -> str:
    """An LLVM double constant, bit-exact."""
    (bits,) = struct.unpack("<Q", struct.pack("<d", float(x)))
    return f"0x{bits:016X}"


def _operand(x) -> str:
    return _literal(x) if isinstance(x, float) else f"%{x}"


_BINARY = {"*": "fmul", "*c": "fmul", "+": "fadd", "+c": "fadd", "-": "fsub", "/": "fdiv"}


def kernel_ir(gen, symbol: str) -> str:
    """LLVM IR of ``gen``: a batch entry and a single-state entry.

    ``void symbol(i64 N, [ptr a_g, i64 stride_g]*, ptr out, i64 so)``: sample ``k`` reads group
    ``g`` at ``a_g[k * stride_g + j]`` and writes output ``j`` at ``out[k * so + j]``.

    ``void symbol_single(ptr in, ptr out)``: one state, the groups packed one after another in
    ``in`` - two arguments, because each argument costs ctypes about 0.15 us.
    """
    params = ["i64 %_N"]
    for g in range(len(gen.groups)):
        params += [f"ptr noalias readonly %_a{g}", f"i64 %_s{g}"]
    params += ["ptr noalias %_out", "i64 %_so"]
    single = [
        f"define void @{symbol}_single(ptr noalias readonly %_in, ptr noalias %_out) nounwind {{"
    ]
    arguments, offset = ["i64 1"], 0
    for g, (_, size) in enumerate(gen.groups):
        single.append(f"  %_g{g} = getelementptr double, ptr %_in, i64 {offset}")
        arguments += [f"ptr %_g{g}", "i64 0"]
        offset += size
    arguments += ["ptr %_out", "i64 0"]
    single += [f"  call void @{symbol}({', '.join(arguments)})", "  ret void", "}"]
    body = (
        single
        + _direct_ir(symbol, [size for _, size in gen.groups], gen.shapes)
        + [
            f"define void @{symbol}({', '.join(params)}) nounwind noinline {{",
            "entry:",
            "  %_none = icmp sle i64 %_N, 0",
            "  br i1 %_none, label %exit, label %loop",
            "loop:",
            "  %_k = phi i64 [0, %entry], [%_next, %loop]",
        ]
    )
    for g, (prefix, size) in enumerate(gen.groups):
        body.append(f"  %_row{g} = mul i64 %_k, %_s{g}")
        for j in range(size):
            body += [
                f"  %_i_{prefix}{j} = add i64 %_row{g}, {j}",
                f"  %_p_{prefix}{j} = getelementptr double, ptr %_a{g}, i64 %_i_{prefix}{j}",
                f"  %{prefix}{j} = load double, ptr %_p_{prefix}{j}",
            ]
    for name, key in gen.ops:
        opcode = key[0]
        if opcode in _BINARY:
            a, b = (_operand(x) for x in key[1:3])
            body.append(f"  %{name} = {_BINARY[opcode]} double {a}, {b}")
        elif opcode == "neg":
            body.append(f"  %{name} = fneg double {_operand(key[1])}")
        elif opcode in ("cos", "sin", "sqrt"):
            body.append(f"  %{name} = call double @llvm.{opcode}.f64(double {_operand(key[1])})")
        elif opcode == "coulomb":
            v, positive, negative = _operand(key[1]), _literal(key[2]), _literal(-key[3])
            body += [
                f"  %_gt_{name} = fcmp ogt double {v}, 0.0",
                f"  %_lt_{name} = fcmp olt double {v}, 0.0",
                f"  %_neg_{name} = select i1 %_lt_{name}, double {negative}, double 0.0",
                f"  %{name} = select i1 %_gt_{name}, double {positive}, double %_neg_{name}",
            ]
        else:
            raise ValueError(f"no instruction for generated operation {opcode!r}")
    body.append("  %_orow = mul i64 %_k, %_so")
    for j, value in enumerate(gen.outputs):
        body += [
            f"  %_oi{j} = add i64 %_orow, {j}",
            f"  %_op{j} = getelementptr double, ptr %_out, i64 %_oi{j}",
            f"  store double {_operand(value)}, ptr %_op{j}",
        ]
    body += [
        "  %_next = add i64 %_k, 1",
        "  %_done = icmp eq i64 %_next, %_N",
        "  br i1 %_done, label %exit, label %loop",
        "exit:",
        "  ret void",
        "}",
        "declare double @llvm.cos.f64(double)",
        "declare double @llvm.sin.f64(double)",
        "declare double @llvm.sqrt.f64(double)",
    ]
    return "\n".join(body) + "\n"


# numpy's array struct (PyArrayObject_fields, numpy/ndarraytypes.h), 64-bit: the byte offsets the
# direct entry reads.  Checked against live arrays before the entry is used (_layout_holds).
_DATA, _NDIM, _DIMS, _STRIDES, _DESCR, _FLAGS = 16, 24, 32, 40, 56, 64
_C_CONTIGUOUS, _ALIGNED, _WRITEABLE = 0x0001, 0x0100, 0x0400  # NPY_ARRAY_* flags
_TYPE = 8  # ob_type in every object's head
_API = ("Py_IncRef", "ndarray", "float64", "None")  # the addresses the direct entry needs


def _direct_ir(symbol: str, sizes: list[int], shapes: list[tuple[int, ...]]) -> list[str]:
    """A METH_FASTCALL entry for one state: ``symbol_direct(*inputs, *outputs)``.

    ``PyObject *symbol_direct(PyObject *self, PyObject *const *args, Py_ssize_t nargs)`` runs the
    kernel on the arrays themselves and returns the first output when every argument is an
    exact ``numpy.ndarray`` of float64 - each input 1-D, unit stride, aligned, of its group's
    size; each output C-contiguous, aligned, writeable, of its shape in ``shapes`` (which
    split the results in order) - else ``None`` with nothing written: the caller then takes
    the general path, which converts or reports.  Several outputs are filled from one row on
    the stack.  Python objects are only read here, and the one reference returned is taken
    through ``Py_IncRef``; the addresses it needs come from the table ``symbol_api`` (filled
    in after loading, since they change from process to process).
    """
    n_in = len(sizes)
    count = n_in + len(shapes)
    n_out = sum(int(np.prod(shape)) for shape in shapes)
    ir = [
        f"@{symbol}_api = global [{len(_API)} x i64] zeroinitializer",
        f"define ptr @{symbol}_direct(ptr %self, ptr %args, i64 %nargs) nounwind {{",
        "entry:",
        f"  %row = alloca [{n_out} x double], align 16",
        f"  %incref = load ptr, ptr @{symbol}_api",
        f"  %p_type = getelementptr i64, ptr @{symbol}_api, i64 1",
        "  %ndarray = load i64, ptr %p_type",
        f"  %p_descr = getelementptr i64, ptr @{symbol}_api, i64 2",
        "  %float64 = load i64, ptr %p_descr",
        f"  %p_none = getelementptr i64, ptr @{symbol}_api, i64 3",
        "  %none = load ptr, ptr %p_none",
        f"  %count_ok = icmp eq i64 %nargs, {count}",
        "  br i1 %count_ok, label %arg0, label %fail",
    ]
    wanted = [(size,) for size in sizes] + [tuple(shape) for shape in shapes]
    for k, shape in enumerate(wanted):
        nxt = f"arg{k + 1}" if k + 1 < count else "run"
        ir += [
            f"arg{k}:",
            f"  %pp{k} = getelementptr ptr, ptr %args, i64 {k}",
            f"  %o{k} = load ptr, ptr %pp{k}",
            f"  %pt{k} = getelementptr i8, ptr %o{k}, i64 {_TYPE}",
            f"  %t{k} = load i64, ptr %pt{k}",
            f"  %tok{k} = icmp eq i64 %t{k}, %ndarray",
            f"  br i1 %tok{k}, label %nd{k}, label %fail",
            f"nd{k}:",  # an ndarray: its fields can be read
            f"  %pn{k} = getelementptr i8, ptr %o{k}, i64 {_NDIM}",
            f"  %n{k} = load i32, ptr %pn{k}",
            f"  %nok{k} = icmp eq i32 %n{k}, {len(shape)}",
            f"  br i1 %nok{k}, label %shape{k}, label %fail",
            f"shape{k}:",  # of the right rank: its dimensions can be read
            f"  %ppd{k} = getelementptr i8, ptr %o{k}, i64 {_DIMS}",
            f"  %pd{k} = load ptr, ptr %ppd{k}",
            f"  %pe{k} = getelementptr i8, ptr %o{k}, i64 {_DESCR}",
            f"  %e{k} = load i64, ptr %pe{k}",
            f"  %ok{k}_e = icmp eq i64 %e{k}, %float64",
        ]
        last = f"%ok{k}_e"
        for axis, extent in enumerate(shape):
            ir += [
                f"  %pd{k}_{axis} = getelementptr i64, ptr %pd{k}, i64 {axis}",
                f"  %d{k}_{axis} = load i64, ptr %pd{k}_{axis}",
                f"  %dok{k}_{axis} = icmp eq i64 %d{k}_{axis}, {extent}",
                f"  %ok{k}_{axis} = and i1 {last}, %dok{k}_{axis}",
            ]
            last = f"%ok{k}_{axis}"
        ir += [
            f"  %ppx{k} = getelementptr i8, ptr %o{k}, i64 {_DATA}",
            f"  %x{k} = load ptr, ptr %ppx{k}",
        ]
        if k < n_in:  # an input: unit stride and an aligned address
            ir += [
                f"  %pps{k} = getelementptr i8, ptr %o{k}, i64 {_STRIDES}",
                f"  %ps{k} = load ptr, ptr %pps{k}",
                f"  %s{k} = load i64, ptr %ps{k}",
                f"  %sok{k} = icmp eq i64 %s{k}, 8",
                f"  %xi{k} = ptrtoint ptr %x{k} to i64",
                f"  %xa{k} = and i64 %xi{k}, 7",
                f"  %aok{k} = icmp eq i64 %xa{k}, 0",
                f"  %ok{k}_s = and i1 {last}, %sok{k}",
                f"  %ok{k} = and i1 %ok{k}_s, %aok{k}",
            ]
        else:  # an output: numpy's flags say C-contiguous, aligned and writeable
            mask = _C_CONTIGUOUS | _ALIGNED | _WRITEABLE
            ir += [
                f"  %pf{k} = getelementptr i8, ptr %o{k}, i64 {_FLAGS}",
                f"  %f{k} = load i32, ptr %pf{k}",
                f"  %fm{k} = and i32 %f{k}, {mask}",
                f"  %fok{k} = icmp eq i32 %fm{k}, {mask}",
                f"  %ok{k} = and i1 {last}, %fok{k}",
            ]
        ir.append(f"  br i1 %ok{k}, label %{nxt}, label %fail")
    arguments = ["i64 1"] + [f"ptr %x{k}, i64 0" for k in range(n_in)]
    ir.append("run:")
    if len(shapes) == 1:  # straight into the one output
        ir.append(f"  call void @{symbol}({', '.join(arguments + [f'ptr %x{n_in}, i64 0'])})")
    else:  # into the row, then each output's part of it
        ir.append(f"  call void @{symbol}({', '.join(arguments + ['ptr %row, i64 0'])})")
        offset = 0
        for k, shape in zip(range(n_in, count), shapes):
            size = int(np.prod(shape))
            ir += [
                f"  %part{k} = getelementptr double, ptr %row, i64 {offset}",
                f"  call void @llvm.memcpy.p0.p0.i64(ptr %x{k}, ptr %part{k}, i64 {8 * size}, "
                "i1 false)",
            ]
            offset += size
    ir += [
        f"  call void %incref(ptr %o{n_in})",
        f"  ret ptr %o{n_in}",
        "fail:",
        "  call void %incref(ptr %none)",
        "  ret ptr %none",
        "}",
        "declare void @llvm.memcpy.p0.p0.i64(ptr, ptr, i64, i1)",
    ]
    return ir


# ------------------------------------------------------------------------------- compile
_COMPILED: dict[str, Kernel] = {}


def compiled_kernel(gen) -> Kernel | None:
    """The compiled kernel of a generated program, or None (numpy fallback).

    Compiled once per process (through :func:`compile_ir`); the object file is cached on disk
    across processes.
    """
    if backend() != "llvm":
        return None
    ir = kernel_ir(gen, "KERNEL")
    key = _cache_key(ir)
    with _LOCK:
        kernel = _COMPILED.get(key)
        if kernel is None:
            symbol = f"rworld_{gen.name}_{key[:20]}"
            addresses = compile_ir(
                gen.name,
                ir.replace("@KERNEL", f"@{symbol}"),
                [symbol, f"{symbol}_single", f"{symbol}_direct", f"{symbol}_api"],
                ir,
            )
            if addresses is None:
                return None
            kernel = _COMPILED[key] = Kernel(gen, *addresses)
        return kernel


def _cache_key(source: str) -> str:
    """The disk cache's name for the object compiled from ``source`` on this LLVM and CPU."""
    _llvm()
    return hashlib.sha256(f"{KERNEL_FORMAT}|{_STATE['host']}|{source}".encode()).hexdigest()


def compile_ir(name: str, build, symbols: list[str], source: str) -> list[int] | None:
    """Machine code for a module of LLVM IR: the addresses of its functions ``symbols``, or None
    when kernels are off (``RWORLD_KERNELS=numpy``, no llvmlite) or compiling failed (with a
    warning naming ``name``).

    ``build`` is the IR text, or a function returning it that runs only when the object is not
    cached (the collision room's GJK: building its IR costs more than loading it).  The cache
    is keyed by ``source`` (what determines the IR: the text itself, or the generator's source
    and constants), the LLVM version and the CPU.  The symbols must be unique to that source
    (put its hash in them).
    """
    if backend() != "llvm":
        return None
    llvm = _llvm()
    key = _cache_key(source)
    with _LOCK:
        if key in _COMPILED_IR:
            return _COMPILED_IR[key]
        try:
            addresses = _load(llvm, key, symbols, build)
        except Exception as error:  # a failed compile must not stop the caller: it falls back
            warnings.warn(
                f"compiling the {name} kernel failed ({type(error).__name__}: {error}); "
                "using numpy",
                stacklevel=3,
            )
            return None
        _COMPILED_IR[key] = addresses
        return addresses


_COMPILED_IR: dict[str, list[int]] = {}


def _load(llvm, key: str, symbols: list[str], ir) -> list[int]:
    """Addresses of ``symbols``: from the disk cache, else compiled from ``ir`` (the text, or a
    function that returns it) and stored when possible."""
    engine = _STATE["engine"]
    name = f"{key}.o"
    obj = _read_cached(name)
    if obj is None:
        module = llvm.parse_assembly(ir() if callable(ir) else ir)
        module.verify()
        tuning = llvm.create_pipeline_tuning_options(speed_level=3)
        builder = llvm.create_pass_builder(_STATE["machine"], tuning)
        builder.getModulePassManager().run(module, builder)
        obj = _STATE["machine"].emit_object(module)
        _write_cached(name, obj)
    ref = llvm.ObjectFileRef.from_data(obj)
    engine.add_object_file(ref)
    engine.finalize_object()
    _STATE["keep"].append(ref)
    addresses = [engine.get_function_address(symbol) for symbol in symbols]
    if not all(addresses):
        raise RuntimeError(f"symbols {symbols} not found after linking")
    return addresses


def _read_cached(name: str) -> bytes | None:
    """A compiled object from the cache, authenticated before the JIT sees it (``cache.py``)."""
    from . import cache

    return cache.read("kernels", name)


def _write_cached(name: str, obj: bytes) -> None:
    """Store it; a cache that cannot be written is not an error."""
    from . import cache

    cache.write("kernels", name, obj)


# ---------------------------------------------------------------------------------- call
_empty = np.empty


def _address(a: np.ndarray) -> int:
    return a.__array_interface__["data"][0]


def _pool(workers: int) -> ThreadPoolExecutor:
    global _POOL
    with _LOCK:
        if _POOL is None or _POOL._max_workers < workers:
            _POOL = ThreadPoolExecutor(max_workers=workers, thread_name_prefix="rworld-kernel")
        return _POOL


class _MethodDef(ctypes.Structure):
    """CPython's ``PyMethodDef``."""

    _fields_ = [
        ("ml_name", ctypes.c_char_p),
        ("ml_meth", ctypes.c_void_p),
        ("ml_flags", ctypes.c_int),
        ("ml_doc", ctypes.c_char_p),
    ]


_METH_FASTCALL = 0x0080


@functools.cache
def _layout_holds() -> bool:
    """Whether live float arrays have their fields at the offsets the direct entry reads (numpy's
    struct has been stable since 1.7; a build where it is not just uses the packing path)."""

    def word(a: np.ndarray, offset: int, kind=ctypes.c_int64) -> int:
        return kind.from_address(id(a) + offset).value

    def flags(a: np.ndarray) -> int:
        return word(a, _FLAGS, ctypes.c_int32)

    a, b = np.zeros(3), np.zeros((2, 3))
    holds = (
        ctypes.sizeof(ctypes.c_void_p) == 8
        and word(a, _TYPE) == id(np.ndarray)
        and word(a, _DATA) == _address(a)
        and word(a, _NDIM, ctypes.c_int32) == 1
        and ctypes.c_int64.from_address(word(a, _DIMS)).value == 3
        and ctypes.c_int64.from_address(word(a, _STRIDES)).value == 8
        and word(a, _DESCR) == id(a.dtype) == id(_FLOAT)
        and word(b, _NDIM, ctypes.c_int32) == 2
        and [ctypes.c_int64.from_address(word(b, _DIMS) + 8 * i).value for i in (0, 1)] == [2, 3]
        and all(flags(x) & _C_CONTIGUOUS and flags(x) & _ALIGNED for x in (a, b))
        and not flags(b.T) & _C_CONTIGUOUS
        and bool(flags(a) & _WRITEABLE)
    )
    a.flags.writeable = False
    return holds and not flags(a) & _WRITEABLE


_FLOAT = np.dtype(float)


def _direct_function(name: str, address: int, api_address: int):
    """A builtin function object whose call runs the direct entry at ``address`` (a
    ``PyMethodDef`` made into a function, as a C extension would), or None when numpy's
    layout is not the one the entry reads."""
    if not _layout_holds():
        return None
    incref = ctypes.cast(ctypes.pythonapi.Py_IncRef, ctypes.c_void_p).value
    if not incref:
        return None
    table = (ctypes.c_uint64 * len(_API)).from_address(api_address)
    table[:] = [incref, id(np.ndarray), id(_FLOAT), id(None)]
    label = f"{name}_direct".encode()
    method = _MethodDef(label, address, _METH_FASTCALL, None)
    new = ctypes.pythonapi.PyCFunction_NewEx
    new.restype = ctypes.py_object
    new.argtypes = [ctypes.c_void_p, ctypes.c_void_p, ctypes.c_void_p]
    function = new(ctypes.addressof(method), None, None)
    _STATE["keep"].append((label, method))  # the function points at these for its lifetime
    return function


class Kernel:
    """A compiled program, called on arrays.

    ``kernel(inputs)`` takes one float array per input group, shape (size,) (one state, or the
    same for every sample) or (N, size), and returns (n_out,) or (N, n_out).
    """

    def __init__(self, gen, address: int, single_address: int, direct: int, api: int):
        self.name = gen.name
        self.sizes = [size for _, size in gen.groups]
        self.n_out = gen.n_out
        #: the outputs of :attr:`direct`, splitting the results in order
        self.shapes = list(gen.shapes)
        argtypes = [ctypes.c_int64] + [ctypes.c_void_p, ctypes.c_int64] * (len(self.sizes) + 1)
        self._fn = ctypes.CFUNCTYPE(None, *argtypes)(address)  # releases the GIL while it runs
        self._single = ctypes.CFUNCTYPE(None, ctypes.c_void_p, ctypes.c_void_p)(single_address)
        self._local = threading.local()
        #: ``direct(*inputs, *outputs)``: one state straight from float arrays into the outputs
        #: (one array of each shape in :attr:`shapes`); returns the first output, or None
        #: (nothing written) when an input is not an exact, aligned, 1-D float64 array of its
        #: size or an output not a C-contiguous, aligned, writeable float64 array of its shape.
        #: The outputs must not share memory with the inputs (the kernel's pointers are
        #: ``noalias``); :attr:`Generated.direct` passes fresh ones.  None when unavailable.
        self.direct = _direct_function(f"{gen.name}", direct, api)
        # __call__'s one-state shortcut: the whole row as one output
        self._flat_direct = self.direct if self.shapes == [(self.n_out,)] else None

    def single(self, inputs) -> np.ndarray:
        """One state: every input 1-D of its group's size; returns a new (n_out,) array.

        Float arrays of the right sizes go straight in through :attr:`direct` (in
        :meth:`__call__`, when its one output is the whole row); other inputs (other dtypes,
        strides) are packed here into a per-thread row whose address was taken once (taking an
        array's address costs numpy 1.6 us)."""
        try:
            buffer, output, addresses = self._local.buffers
        except AttributeError:  # first call on this thread: its own rows, addresses taken once
            buffer, output = np.zeros(sum(self.sizes)), np.zeros(self.n_out)
            addresses = (_address(buffer), _address(output))
            self._local.buffers = buffer, output, addresses
        try:
            if len(inputs) == 1:
                buffer[:] = inputs[0]
            else:
                np.concatenate(inputs, out=buffer)
        except ValueError:  # also when the sizes add up wrong
            raise ValueError(
                f"{self.name}: inputs of shapes {[np.shape(x) for x in inputs]} where "
                f"{[(size,) for size in self.sizes]} are expected"
            ) from None
        self._single(*addresses)
        return output.copy()

    def __call__(self, inputs) -> np.ndarray:
        direct = self._flat_direct
        if direct is not None:  # one state of float arrays: no checks in Python
            out = _empty(self.n_out)
            if direct(*inputs, out) is out:
                return out
        for x in inputs:
            if x.ndim != 1:
                break
        else:
            return self.single(inputs)
        if len(inputs) != len(self.sizes):
            raise ValueError(f"{self.name}: {len(self.sizes)} inputs expected, got {len(inputs)}")
        N = next(len(x) for x in inputs if x.ndim == 2)
        arrays, strides = [], []
        for x, size in zip(inputs, self.sizes):
            x = np.ascontiguousarray(x, dtype=float)
            if x.shape[-1] != size or (x.ndim == 2 and len(x) != N) or x.ndim > 2:
                raise ValueError(
                    f"{self.name}: input of shape {x.shape} where ({size},) or ({N}, {size}) "
                    "is expected"
                )
            arrays.append(x)
            strides.append(size if x.ndim == 2 else 0)
        out = np.empty((N, self.n_out))
        addresses = [_address(x) for x in arrays]
        out_address = _address(out)

        def run(start: int, stop: int) -> None:
            argv: list[int] = [stop - start]
            for address, stride in zip(addresses, strides):
                argv += [address + 8 * start * stride, stride]
            argv += [out_address + 8 * start * self.n_out, self.n_out]
            self._fn(*argv)

        workers = thread_count() if N >= PARALLEL_MIN else 1
        if workers == 1:
            run(0, N)
        else:
            bounds = np.linspace(0, N, workers + 1).astype(int)
            futures = [
                _pool(workers).submit(run, int(a), int(b)) for a, b in zip(bounds[:-1], bounds[1:])
            ]
            for future in futures:
                future.result()
        return out
