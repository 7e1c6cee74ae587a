"""Where the rendering kernel spends its time, by source line: `perf` samples of a render mapped onto
the numba kernels' machine code through their DWARF line tables.

    python benchmarks/profile_kernel.py scenes/bunnies.xml --spp 32 --seconds 8
    python benchmarks/profile_kernel.py scenes/dof.xml --threads 1 --top 60 --by function

The kernels are compiled once with debug line information (`NUMBA_DEBUGINFO=1`, their own cache
directory, so the normal cache is untouched; the code is otherwise optimised as usual).  The script
renders the scene repeatedly for `--seconds` under `perf record -p <this process>`, then attributes
every sample: to Embree (libembree4), to another library, or to the instruction of a numba kernel it
fell in - found in the exact ELF object numba loaded (`CodeLibrary._get_compiled_object()`),
disassembled by `objdump -dl`, whose line table names the source line of every instruction, inlined
callees included.  Printed: the share per library, then the hottest source lines (or functions) of the
kernels with their share of all samples.  Needs `perf` (linux-perf) and `objdump` (binutils).
"""
from __future__ import annotations

import argparse
import bisect
import collections
import hashlib
import os
import re
import signal
import subprocess
import sys
import tempfile
import time
from pathlib import Path

ROOT = Path(__file__).resolve().parents[1]


def _debug_cache_dir() -> str:
    digest = hashlib.sha256()
    for source in sorted((ROOT / 'renderer').rglob('*.py')):
        digest.update(source.relative_to(ROOT).as_posix().encode())
        digest.update(source.read_bytes())
    return str(Path(tempfile.gettempdir()) / 'rtc_profile_cache' / ('v4-' + digest.hexdigest()[:16]))


os.environ['NUMBA_DEBUGINFO'] = '1'
os.environ['NUMBA_CACHE_DIR'] = _debug_cache_dir()

import numba  # noqa: E402
from numba.core import codegen as _codegen  # noqa: E402
from numba.core import cpu as _cpu  # noqa: E402
from numba.core import lowering as _lowering  # noqa: E402

# Line tables, not a debug build: numba's full debug info (what NUMBA_DEBUGINFO=1 alone gives) also turns
# on bounds checks, extends variable lifetimes and marks every function `noinline`, which would profile
# another program.  Those three are undone here; the debug records (line tables) stay.
_finalize = _cpu.CPUTargetOptions.finalize
_pre_lower = _lowering.Lower.pre_lower


def _no_debug_build(self, flags, options):
    _finalize(self, flags, options)
    if flags.debuginfo:
        flags.boundscheck = False
        flags.dbg_extend_lifetimes = False


def _inlinable(self):
    _pre_lower(self)
    self.builder.function.attributes.discard('noinline')


_cpu.CPUTargetOptions.finalize = _no_debug_build
_lowering.Lower.pre_lower = _inlinable

# Every object file the JIT loads, with its library: numba hands a library's object code to LLVM
# through these two hooks (compiled now, or read from the cache) and then drops it.
_OBJECTS = []
_Lib = _codegen.CPUCodeLibrary
_compiled_hook, _getbuffer_hook = _Lib._object_compiled_hook.__func__, _Lib._object_getbuffer_hook.__func__


def _keep_compiled(cls, ll_module, buf):
    lib = getattr(ll_module, '_CPUCodeLibrary__library', None)
    if lib is not None and buf:
        _OBJECTS.append((lib, bytes(buf)))
    return _compiled_hook(cls, ll_module, buf)


def _keep_loaded(cls, ll_module):
    buf = _getbuffer_hook(cls, ll_module)
    lib = getattr(ll_module, '_CPUCodeLibrary__library', None)
    if lib is not None and buf:
        _OBJECTS.append((lib, bytes(buf)))
    return buf


_Lib._object_compiled_hook = classmethod(_keep_compiled)
_Lib._object_getbuffer_hook = classmethod(_keep_loaded)

# numba's line table names the file of the function being compiled, also for statements inlined from
# other files (`inline='always'`), so a line number alone is ambiguous.  While lowering, the file is
# encoded in the line: FILE_STRIDE * (1 + index of the file among the renderer's sources) + line
# (0 for numba's own and other files).
from numba.core.lowering import Lower  # noqa: E402

FILE_STRIDE = 100000
SOURCES = sorted(str(p) for p in (ROOT / 'renderer').rglob('*.py'))
_lower_inst = Lower.lower_inst


def _lower_inst_with_file(self, inst):
    loc = self.loc
    try:
        fid = SOURCES.index(str(Path(loc.filename).resolve())) + 1
    except (ValueError, TypeError, OSError):
        fid = 0
    self.loc = loc.with_lineno(fid * FILE_STRIDE + loc.line)
    try:
        return _lower_inst(self, inst)
    finally:
        self.loc = loc


Lower.lower_inst = _lower_inst_with_file


def decode(line: int) -> tuple[str, int]:
    fid, ln = divmod(line, FILE_STRIDE)
    return (SOURCES[fid - 1] if 0 < fid <= len(SOURCES) else '(numba)'), ln


_FUNC = re.compile(r'^([0-9a-f]+) <(.+)>:$')
_INSN = re.compile(r'^\s+([0-9a-f]+):\s')
_LINE = re.compile(r'^(/.+):(\d+)(?: \(discriminator \d+\))?$')


def _code_section(path: str) -> str:
    """numba compiles with the large code model: its code is in .ltext (else .text)."""
    out = subprocess.run(['objdump', '-h', path], check=True, capture_output=True, text=True).stdout
    return '.ltext' if re.search(r'\s\.ltext\s+0*[1-9a-f]', out) else '.text'


def disassemble(obj_bytes: bytes):
    """-> (functions [(start, end, name)], instructions [(offset, file, line)]) of an ELF object,
    offsets relative to its code section."""
    with tempfile.NamedTemporaryFile(suffix='.o') as f:
        f.write(obj_bytes)
        f.flush()
        out = subprocess.run(['objdump', '-dl', '--no-show-raw-insn', '-j', _code_section(f.name), f.name],
                             check=True, capture_output=True, text=True).stdout
    funcs, insns = [], []
    src = ('?', 0)
    for ln in out.splitlines():
        m = _FUNC.match(ln)
        if m:
            funcs.append([int(m.group(1), 16), None, m.group(2)])
            continue
        m = _LINE.match(ln)
        if m:
            src = (m.group(1), int(m.group(2)))
            continue
        m = _INSN.match(ln)
        if m:
            insns.append((int(m.group(1), 16), src[0], src[1]))
    end = insns[-1][0] + 16 if insns else 0
    for i, fn in enumerate(funcs):
        fn[1] = funcs[i + 1][0] if i + 1 < len(funcs) else end
    return [tuple(f) for f in funcs], insns


def text_base(lib, obj_bytes: bytes) -> int | None:
    """Address at which the JIT placed the object's code section: that of one of its exported functions
    minus the function's offset in the object."""
    with tempfile.NamedTemporaryFile(suffix='.o') as f:
        f.write(obj_bytes)
        f.flush()
        out = subprocess.run(['nm', '--defined-only', f.name], check=True, capture_output=True, text=True).stdout
    for ln in out.splitlines():
        parts = ln.split()
        if len(parts) == 3 and parts[1] in 'Tt' and not parts[2].startswith('.'):
            addr = lib.get_pointer_to_function(parts[2])
            if addr:
                return addr - int(parts[0], 16)
    return None


def _arguments(argv):
    ap = argparse.ArgumentParser(description=__doc__.split('\n\n')[0])
    ap.add_argument('scene')
    ap.add_argument('--width', type=int, default=320)
    ap.add_argument('--height', type=int, default=240)
    ap.add_argument('--spp', type=int, default=16)
    ap.add_argument('--sampler', default='sobol')
    ap.add_argument('--filter', default='gaussian')
    ap.add_argument('--max-depth', type=int, default=4)
    ap.add_argument('--integrator', choices=['cook', 'path'], default=None, help="default: the stage's")
    ap.add_argument('--threads', type=int, default=1)
    ap.add_argument('--seconds', type=float, default=8.0)
    ap.add_argument('--frequency', type=int, default=4000, help='perf sampling frequency (Hz)')
    ap.add_argument('--top', type=int, default=40)
    ap.add_argument('--by', choices=('line', 'file', 'function'), default='line')
    return ap.parse_args(argv)


def _renderer(a):
    """The scene's renderer and options, its kernel loaded (or compiled)."""
    from rtc.renderer.host.render import RenderOptions, Renderer
    if a.scene.lower().endswith('.xml'):
        from rtc.cli import load_scene
        desc = load_scene(a.scene, quiet=True)
    else:
        from rtc.renderer.usd.stage import read_stage
        desc = read_stage(a.scene)
    numba.set_num_threads(a.threads)
    opts = RenderOptions(width=a.width, height=a.height, spp=a.spp, sampler=a.sampler, filter=a.filter,
                         max_depth=a.max_depth, integrator=a.integrator)
    r = Renderer(desc, threads=a.threads)
    t0 = time.perf_counter()
    r.render(RenderOptions(**{**opts.__dict__, 'spp': 1}))
    print(f'kernel ready in {time.perf_counter() - t0:.1f} s (debug-info build, cache {os.environ["NUMBA_CACHE_DIR"]})',
          flush=True)
    return r, opts


def _perf_script(r, opts, a) -> str:
    """`perf script` lines (ip, dso) of renders repeated for `a.seconds`."""
    with tempfile.TemporaryDirectory() as tmp:
        data = os.path.join(tmp, 'perf.data')
        perf = subprocess.Popen(['perf', 'record', '-F', str(a.frequency), '-p', str(os.getpid()), '-o', data],
                                stdout=subprocess.DEVNULL, stderr=subprocess.PIPE)
        time.sleep(0.5)
        renders, t0 = 0, time.perf_counter()
        while time.perf_counter() - t0 < a.seconds:
            r.render(opts)
            renders += 1
        perf.send_signal(signal.SIGINT)
        perf.wait()
        script = subprocess.run(['perf', 'script', '-i', data, '-F', 'ip,dso'], capture_output=True, text=True)
    print(f'{renders} renders of {a.width}x{a.height} at {a.spp} spp, {a.threads} thread(s)')
    return script.stdout


def _kernel_ranges():
    """The kernels' code: every library's .text, located through one exported symbol:
    (start address, end address, functions, instructions, text base), sorted."""
    ranges = []
    for lib, obj in _OBJECTS:
        base = text_base(lib, obj)
        if base is None:
            continue
        funcs, insns = disassemble(obj)
        if insns:
            ranges.append((base, base + insns[-1][0] + 16, funcs, insns, base))
    ranges.sort()
    return ranges


def _attribute(script: str, ranges, by: str):
    """Samples per library and per kernel source line / file / function: (total, by_dso, by_key)."""
    starts = [rg[0] for rg in ranges]
    by_dso = collections.Counter()
    by_key = collections.Counter()
    total = 0
    for ln in script.splitlines():
        parts = ln.split(None, 1)
        if len(parts) != 2:
            continue
        try:
            ip = int(parts[0], 16)
        except ValueError:
            continue
        total += 1
        dso = parts[1].strip().strip('()')
        i = bisect.bisect_right(starts, ip) - 1
        if i >= 0 and ip < ranges[i][1]:
            _, _, funcs, insns, base = ranges[i]
            off = ip - base
            k = bisect.bisect_right([x[0] for x in insns], off) - 1
            _, _, line = insns[k]
            path, line = decode(line)
            by_dso['numba kernels'] += 1
            if by == 'function':
                j = bisect.bisect_right([f[0] for f in funcs], off) - 1
                by_key[funcs[j][2][:110]] += 1
            elif by == 'file':
                by_key[os.path.basename(path)] += 1
            else:
                by_key[(path, line)] += 1
        else:
            by_dso[os.path.basename(dso) or '?'] += 1
    return total, by_dso, by_key


def _report(total, by_dso, by_key, a) -> None:
    print(f'{total} samples')
    for dso, n in by_dso.most_common(8):
        print(f'  {100 * n / total:5.1f} %  {dso}')
    print(f'hottest {dict(line="source lines", file="files", function="functions")[a.by]} of the numba kernels '
          f'(% of all samples):')
    lines_cache = {}
    for key, n in by_key.most_common(a.top):
        if a.by != 'line':
            print(f'  {100 * n / total:5.1f} %  {key}')
            continue
        path, line = key
        if path not in lines_cache:
            try:
                lines_cache[path] = Path(path).read_text().splitlines()
            except OSError:
                lines_cache[path] = []
        text = lines_cache[path][line - 1].strip() if 0 < line <= len(lines_cache[path]) else ''
        print(f'  {100 * n / total:5.1f} %  {os.path.basename(path)}:{line:<5d} {text[:90]}')


def main(argv=None) -> int:
    a = _arguments(argv)
    r, opts = _renderer(a)
    script = _perf_script(r, opts, a)
    total, by_dso, by_key = _attribute(script, _kernel_ranges(), a.by)
    if not total:
        print('no samples (is perf allowed? see /proc/sys/kernel/perf_event_paranoid)')
        return 1
    _report(total, by_dso, by_key, a)
    r.close()
    return 0


if __name__ == '__main__':
    sys.exit(main())
