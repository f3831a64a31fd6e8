"""The machine's own cycle-to-cycle spread, against which wbc's p99/median (#26, target 3) is read:
fixed C++ work of ~200 µs per "cycle", each cycle timed in thread CPU time, 6000 cycles, p99/median
over all cycles and over the calm ones (neither it nor the cycle before preempted).

    PYTHONPATH=. python benchmarks/machine_spread.py [ROUNDS]      (main venv: builds, then runs
        benchmarks/machine_spread.cpp's modes alternated, ROUNDS times: pinocchio's calls on Talos,
        a pure arithmetic chain, pointer chases in the L2, the L3 and memory)
    PYTHONPATH=. python benchmarks/machine_spread.py placo [ROUNDS]   (peer venv: PlaCo's
        DynamicsSolver.solve on benchmarks/harness/peers.py's Talos set-up, per cycle)

The C++ program is built with g++ against the pinocchio of this venv (cmeel's headers and
libraries; Eigen's headers from the system, e.g. ``apt-get install libeigen3-dev``), the Talos
model handed over in pinocchio's binary serialisation, in ``$TMPDIR/wbc_machine_spread``.
"""

from __future__ import annotations

import os
import resource
import shutil
import subprocess
import sys
import tempfile
import time
import warnings
from pathlib import Path

import numpy as np

HERE = Path(__file__).resolve().parent
MODES = ("pin", "alu", "chase256", "chase4096", "chase65536")
CYCLES, TARGET_US = 6000, 200


def build() -> tuple[Path, Path]:
    """(the program, the model file), built if missing or older than the source."""
    import pinocchio as pin

    from wbc.robot.loader import load_robot

    out = Path(tempfile.gettempdir()) / "wbc_machine_spread"
    out.mkdir(exist_ok=True)
    exe, model = out / "machine_spread", out / "talos.bin"
    load_robot("talos").model.saveToBinary(str(model))
    src = HERE / "machine_spread.cpp"
    if exe.exists() and exe.stat().st_mtime > src.stat().st_mtime:
        return exe, model
    prefix = next(p for p in Path(pin.__file__).parents if p.name == "cmeel.prefix")
    eigen = next((d for d in ("/usr/include/eigen3", "/usr/local/include/eigen3") if Path(d, "Eigen").is_dir()), None)
    if eigen is None or shutil.which("g++") is None:
        sys.exit("needs g++ and Eigen's headers (apt-get install g++ libeigen3-dev)")
    defs = ["BOOST_MPL_CFG_NO_PREPROCESSED_HEADERS", "BOOST_MPL_LIMIT_LIST_SIZE=30", "BOOST_MPL_LIMIT_VECTOR_SIZE=30",
            "BOOST_FUSION_INVOKE_MAX_ARITY=12", "PINOCCHIO_ENABLE_TEMPLATE_INSTANTIATION", "NDEBUG"]
    cmd = ["g++", "-O2", *(f"-D{d}" for d in defs), f"-I{prefix}/include", f"-I{eigen}", str(src), "-o", str(exe),
           f"-L{prefix}/lib", f"-Wl,-rpath,{prefix}/lib", "-lpinocchio_default", "-lboost_serialization"]
    subprocess.run(cmd, check=True)
    return exe, model


def placo(rounds: int) -> None:
    """PlaCo's solve per cycle in thread time (peers.PlacoDynamicsRun times it with
    ``time.perf_counter``, pointed at ``time.thread_time`` for the run)."""
    from benchmarks.harness import peers
    from wbc.robot.loader import load_robot

    warnings.simplefilter("ignore")
    for _ in range(rounds):
        run = peers.PlacoDynamicsRun(load_robot("talos"))
        th, sw = np.empty(CYCLES), np.zeros(CYCLES, dtype=np.int64)
        real = time.perf_counter
        time.perf_counter = time.thread_time
        try:
            for k in range(200 + CYCLES):
                r0 = resource.getrusage(resource.RUSAGE_THREAD).ru_nivcsw
                t = run.step(k)[0]
                if k >= 200:
                    th[k - 200] = t * 1e6
                    sw[k - 200] = resource.getrusage(resource.RUSAGE_THREAD).ru_nivcsw - r0
        finally:
            time.perf_counter = real
        s = sw > 0
        calm = ~s & ~np.r_[False, s[:-1]]
        m, p = np.median(th), np.percentile(th, 99)
        print(f"placo      thread median {m:6.1f} us p99 {p:6.1f} ({p / m:.2f}x); calm "
              f"{np.percentile(th[calm], 99) / np.median(th[calm]):.2f}x; {int(s.sum())} of {CYCLES} preempted; "
              f"load {os.getloadavg()[0]:.1f}", flush=True)


def main() -> None:
    args = sys.argv[1:]
    if args and args[0] == "placo":
        placo(int(args[1]) if len(args) > 1 else 1)
        return
    exe, model = build()
    for r in range(int(args[0]) if args else 1):
        print(f"round {r}, load {os.getloadavg()[0]:.1f}", flush=True)
        for mode in MODES:
            subprocess.run([str(exe), str(model), mode, str(CYCLES), str(TARGET_US)], check=True)


if __name__ == "__main__":
    main()
