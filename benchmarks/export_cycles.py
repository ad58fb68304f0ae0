"""Cycles of an exported C policy on a Cortex-M4 with FPU: emulated, counted, weighted by the TRM.

Each exported ``policy.c`` (``rbenv export``) is cross-compiled as flight code
(``arm-none-eabi-gcc -std=c99 -O2 -mcpu=cortex-m4 -mthumb -mfpu=fpv4-sp-d16 -mfloat-abi=hard``)
and linked with newlib's libm, the C library the toolchain ships. Unicorn (a CPU emulator,
QEMU's ARM core, Cortex-M4 model) then runs ``rbenv_policy`` on raw observations of the run's
env, and every executed instruction is counted, by function, and weighted by its cycle count
in the Arm Cortex-M4 Technical Reference Manual (DDI 0439B: Table 3-1 for the integer core,
Table 7-1 for the FPU; :data:`FPU_CYCLES`, :func:`cycles`). The result is an estimate for memory
with no wait states (what the TRM tables assume), not a measurement on silicon; flash wait
states at 40-80 MHz add to the loads of the weights (see docs/export.md). The emulated action
is compared with the host's compiled C, so the count is of a run that computed the right thing.

Run: ``python -m benchmarks.export_cycles [--policy DIR ...] [--observations N] [--quick]``
(needs ``gcc-arm-none-eabi``, ``libnewlib-arm-none-eabi`` and the bench extra's unicorn and
capstone). Writes ``export_cycles.json`` and ``export_cycles.png``.
"""

from __future__ import annotations

import argparse
import json
import re
import shutil
import struct
import subprocess
import tempfile
from pathlib import Path

import numpy as np

from benchmarks.common import pyplot, save_figure, write_json

ROOT = Path(__file__).resolve().parent.parent
SHIPPED = [ROOT / "docs" / "export" / "ppo-reorient", ROOT / "docs" / "innocube" / "export"]
ARM_FLAGS = ("-std=c99", "-O2", "-mcpu=cortex-m4", "-mthumb", "-mfpu=fpv4-sp-d16",
             "-mfloat-abi=hard")
CLOCKS_HZ = (40e6, 80e6)
LOOP_S = 1.0  # InnoCube's attitude loop runs at 1 Hz
MARGIN = 100  # the requirement: the policy takes at most 1/100 of the loop

# Arm Cortex-M4 TRM (DDI 0439B) Table 7-1, FPU instruction timings (N: registers transferred).
FPU_CYCLES = {"vadd": 1, "vsub": 1, "vmul": 1, "vnmul": 1, "vabs": 1, "vneg": 1, "vcmp": 1,
              "vcmpe": 1, "vcvt": 1, "vcvtr": 1, "vmrs": 1, "vmsr": 1, "vmov": 1,
              "vmla": 3, "vmls": 3, "vnmla": 3, "vnmls": 3, "vfma": 3, "vfms": 3, "vfnma": 3,
              "vfnms": 3, "vdiv": 14, "vsqrt": 14, "vldr": 2, "vstr": 2}
FPU_MULTIPLE = ("vldm", "vstm", "vpush", "vpop")  # 1 + N
# Table 3-1 (integer core): loads and stores 2, load/store multiple 1 + N, divide 2-12 (taken
# as 12, the worst case), a taken branch 1 + P with P the pipeline refill, 1-3 (taken as 2).
BRANCH_REFILL = 2


def cycles(mnemonic: str, op_str: str, taken: bool) -> int:
    """Cycles of one executed instruction by the TRM's tables (zero wait-state memory)."""
    m = mnemonic.lower().split(".")[0]
    m = re.sub(r"(eq|ne|cs|hs|cc|lo|mi|pl|vs|vc|hi|ls|ge|lt|gt|le|al)$", "", m) \
        if m not in FPU_CYCLES and not m.startswith(("b", "v")) else m
    n_regs = len(re.findall(r"\b[rsd]\d+\b|\blr\b|\bpc\b", op_str.split("{", 1)[-1])) \
        if "{" in op_str else 0
    if m.startswith("v"):
        for name in FPU_MULTIPLE:
            if m.startswith(name):
                doubles = len(re.findall(r"\bd\d+\b", op_str))
                return 1 + n_regs + doubles
        base = m.rstrip("0123456789")
        for name in sorted(FPU_CYCLES, key=len, reverse=True):
            if base.startswith(name):
                return FPU_CYCLES[name]
        return 1
    if m in ("ldm", "ldmia", "ldmdb", "stm", "stmia", "stmdb", "push", "pop"):
        return 1 + n_regs + (BRANCH_REFILL if "pc" in op_str and m in ("pop", "ldm") else 0)
    if m in ("ldrd", "strd"):
        return 3
    if m.startswith(("ldr", "str")):
        return 2
    if m in ("sdiv", "udiv"):
        return 12
    if m.startswith(("b", "cb")) and m not in ("bic", "bics", "bfi", "bfc"):
        return 1 + (BRANCH_REFILL if taken else 0)
    return 1


def arm_tools() -> dict:
    tools = {name: shutil.which(f"arm-none-eabi-{name}") for name in ("gcc", "nm", "size")}
    missing = [f"arm-none-eabi-{k}" for k, v in tools.items() if v is None]
    if missing:
        raise SystemExit(f"{', '.join(missing)} not found: apt-get install gcc-arm-none-eabi "
                         "libnewlib-arm-none-eabi")
    return tools


def build(folder: Path, tmp: Path, tools: dict) -> tuple[Path, dict]:
    """The linked image (rbenv_policy at its entry) and the section sizes of policy.o alone."""
    obj, elf = tmp / "policy.o", tmp / "policy.elf"
    subprocess.run([tools["gcc"], *ARM_FLAGS, "-c", str(folder / "policy.c"), "-o", str(obj)],
                   check=True)
    subprocess.run([tools["gcc"], *ARM_FLAGS, "-ffunction-sections", "-fdata-sections",
                    "-nostartfiles", "--specs=nosys.specs", "-Wl,-e,rbenv_policy",
                    "-Wl,--gc-sections", "-Wl,-Ttext=0x10000", str(folder / "policy.c"),
                    "-o", str(elf), "-lm"], check=True)
    sizes = {}
    for line in subprocess.run([tools["size"], "-A", str(obj)], capture_output=True,
                               text=True, check=True).stdout.splitlines():
        parts = line.split()
        if len(parts) >= 2 and parts[0].startswith(".") and parts[1].isdigit():
            sizes[parts[0]] = int(parts[1])
    return elf, sizes


def functions(elf: Path, tools: dict) -> list[tuple[int, int, str]]:
    """(start, end, name) of every function symbol in the image."""
    out = []
    for line in subprocess.run([tools["nm"], "-S", "--defined-only", str(elf)],
                               capture_output=True, text=True, check=True).stdout.splitlines():
        parts = line.split()
        if len(parts) == 4 and parts[2] in "tTwW":
            start = int(parts[0], 16) & ~1
            out.append((start, start + int(parts[1], 16), parts[3]))
    return sorted(out)


class Emulator:
    """``rbenv_policy`` of a linked Cortex-M4 image, run in Unicorn, instructions counted."""

    STACK, OBS, ACT, STOP = 0x20070000, 0x20080000, 0x20081000, 0x000F0000

    def __init__(self, elf: Path, funcs: list):
        import capstone
        from unicorn import UC_ARCH_ARM, UC_HOOK_CODE, UC_MODE_MCLASS, UC_MODE_THUMB, Uc
        from unicorn import arm_const as arm

        self.arm, self.funcs = arm, funcs
        data = elf.read_bytes()
        entry, phoff = struct.unpack_from("<II", data, 0x18)
        phentsize, phnum = struct.unpack_from("<HH", data, 0x2A)
        self.uc = uc = Uc(UC_ARCH_ARM, UC_MODE_THUMB | UC_MODE_MCLASS)
        uc.ctl_set_cpu_model(arm.UC_CPU_ARM_CORTEX_M4)
        uc.mem_map(0, 0x100000)
        uc.mem_map(0x20000000, 0x100000)
        self.image = {}
        for i in range(phnum):
            kind, off, vaddr, _, filesz, _ = struct.unpack_from("<IIIIII", data,
                                                                phoff + i * phentsize)
            if kind == 1:  # PT_LOAD
                self.image[vaddr] = data[off:off + filesz]
        self.entry = entry
        self.dis = capstone.Cs(capstone.CS_ARCH_ARM,
                               capstone.CS_MODE_THUMB | capstone.CS_MODE_MCLASS)
        self.decoded = {}
        uc.hook_add(UC_HOOK_CODE, self._hook)

    def _hook(self, uc, address, size, _):
        prev = self.prev
        if prev is not None:
            taken = address != prev[0] + prev[1]
            self._account(prev, taken)
        self.prev = (address, size)

    def _account(self, insn, taken: bool) -> None:
        address, size = insn
        if address not in self.decoded:
            code = bytes(self.uc.mem_read(address, size))
            ins = next(self.dis.disasm(code, address), None)
            name = next((n for s, e, n in self.funcs if s <= address < e), "?")
            self.decoded[address] = (ins.mnemonic if ins else "?", ins.op_str if ins else "",
                                     name)
        mnemonic, op_str, name = self.decoded[address]
        c = cycles(mnemonic, op_str, taken)
        self.count["instructions"] += 1
        self.count["cycles"] += c
        per = self.by_function.setdefault(name, [0, 0])
        per[0] += 1
        per[1] += c

    def __call__(self, obs: np.ndarray, act_dim: int) -> tuple[np.ndarray, dict]:
        arm, uc = self.arm, self.uc
        for vaddr, chunk in self.image.items():  # fresh data (errno) for every call
            uc.mem_write(vaddr, chunk)
        uc.mem_write(self.OBS, np.asarray(obs, np.float32).tobytes())
        uc.reg_write(arm.UC_ARM_REG_SP, self.STACK)
        uc.reg_write(arm.UC_ARM_REG_R0, self.OBS)
        uc.reg_write(arm.UC_ARM_REG_R1, self.ACT)
        uc.reg_write(arm.UC_ARM_REG_LR, self.STOP | 1)
        uc.reg_write(arm.UC_ARM_REG_FPEXC, 1 << 30)  # the FPU enabled, as startup code does
        self.prev, self.count, self.by_function = None, {"instructions": 0, "cycles": 0}, {}
        uc.emu_start(self.entry | 1, self.STOP, count=50_000_000)
        self._account(self.prev, True)  # the return
        action = np.frombuffer(bytes(uc.mem_read(self.ACT, 4 * act_dim)), np.float32).copy()
        return action, {"count": dict(self.count), "by_function": dict(self.by_function)}


def observations(info: dict, n: int) -> np.ndarray:
    """Raw observations of ``n`` seeded episodes' starts and their 10th steps (zero action)."""
    import gymnasium as gym

    import rbenv  # noqa: F401  (registers the ids)

    envs = gym.make_vec(info["env_id"], num_envs=n, vectorization_mode="vector_entry_point",
                        **{"scene": info["scene"], **info.get("env_kwargs", {})})
    obs, _ = envs.reset(seed=0)
    first = np.asarray(obs, np.float32).copy()
    for _ in range(10):
        obs, *_ = envs.step(np.zeros(envs.action_space.shape, np.float32))
    envs.close()
    return np.concatenate([first, np.asarray(obs, np.float32)])[:n]


def measure(folder: Path, n_obs: int, tools: dict) -> dict:
    from rbenv.agents.policies.compiled import CPolicy

    info = json.loads((folder / "export.json").read_text())
    fp = json.loads((folder / "footprint.json").read_text())
    with tempfile.TemporaryDirectory(prefix="rbenv-cycles-") as tmp:
        elf, sizes = build(folder, Path(tmp), tools)
        emulate = Emulator(elf, functions(elf, tools))
        obs = observations(info, n_obs)
        host, _ = CPolicy(folder / "policy.c").predict(obs)
        runs, worst = [], 0.0
        for o, want in zip(obs, host, strict=True):
            action, stats = emulate(o, info["act_dim"])
            worst = max(worst, float(np.max(np.abs(action - want))))
            runs.append(stats)
    total = np.array([r["count"]["cycles"] for r in runs])
    instr = np.array([r["count"]["instructions"] for r in runs])
    names = sorted({k for r in runs for k in r["by_function"]})
    by_function = {k: float(np.mean([r["by_function"].get(k, [0, 0])[1] for r in runs]))
                   for k in names}
    calls = fp["transcendental_calls"]
    tanh = sum(by_function.get(k, 0.0) for k in ("tanhf", "expm1f", "fabsf"))
    result = {
        "policy": str(folder.relative_to(ROOT)) if folder.is_relative_to(ROOT) else str(folder),
        "run": info.get("run"), "algo": info.get("algo"), "env_id": info.get("env_id"),
        "scene": info.get("scene"), "footprint": fp, "object_sections": sizes,
        "observations": len(obs), "max_abs_diff_to_host_c": worst,
        "instructions_per_call": {"mean": float(instr.mean()), "max": int(instr.max())},
        "cycles_per_call": {"mean": float(total.mean()), "max": int(total.max())},
        "cycles_by_function": by_function,
        # The policy's own code (dense, whether inlined or not, the normalisation, the
        # activation loops, the output stage's arithmetic; no libm) per multiply-add.
        "cycles_per_multiply_add": sum(v for k, v in by_function.items()
                                       if k == "rbenv_policy" or k.startswith("dense"))
        / fp["multiply_adds"],
        "cycles_per_tanhf": tanh / calls["tanhf"] if calls.get("tanhf") else None,
    }
    result["time_per_call_ms"] = {f"{hz / 1e6:g} MHz": 1e3 * total.max() / hz for hz in CLOCKS_HZ}
    result["margin_at_1_Hz"] = {f"{hz / 1e6:g} MHz": LOOP_S * hz / total.max()
                                for hz in CLOCKS_HZ}
    return result


def plot(results: list[dict]):
    plt = pyplot()
    fig, ax = plt.subplots(figsize=(7, 0.9 + 0.7 * len(results)))
    labels = [f"{r['algo']} {r['scene']}\n{'-'.join(map(str, r['footprint']['layers']))}"
              for r in results]
    for i, hz in enumerate(CLOCKS_HZ):
        ms = [r["time_per_call_ms"][f"{hz / 1e6:g} MHz"] for r in results]
        ax.barh(np.arange(len(results)) + 0.35 * i, ms, height=0.35, label=f"{hz / 1e6:g} MHz")
    ax.axvline(1e3 * LOOP_S / MARGIN, color="k", ls="--",
               label=f"1/{MARGIN} of a 1 Hz loop ({1e3 * LOOP_S / MARGIN:g} ms)")
    ax.set_yticks(np.arange(len(results)) + 0.175, labels)
    ax.set_xlabel("time per call on a Cortex-M4 with FPU (ms, TRM cycle estimate, worst "
                  "observation)")
    ax.legend(fontsize=8)
    fig.tight_layout()
    return fig


def main(argv=None) -> None:
    p = argparse.ArgumentParser(prog="python -m benchmarks.export_cycles",
                                description=__doc__.split("\n\n")[0])
    p.add_argument("--policy", action="append", type=Path, default=None, metavar="DIR",
                   help="an rbenv export folder (default: the shipped ones that exist)")
    p.add_argument("--observations", type=int, default=64)
    p.add_argument("--quick", action="store_true", help="4 observations of the first policy")
    args = p.parse_args(argv)
    tools = arm_tools()
    folders = args.policy or [f for f in SHIPPED if (f / "policy.c").is_file()]
    if args.quick:
        folders, args.observations = folders[:1], 4
    results = [measure(Path(f).resolve(), args.observations, tools) for f in folders]
    for r in results:
        print(f"{r['policy']}: {r['cycles_per_call']['max']} cycles per call (worst of "
              f"{r['observations']}), {r['cycles_per_multiply_add']:.2f} per multiply-add, "
              f"{r['cycles_per_tanhf'] or 0:.0f} per tanhf; "
              + ", ".join(f"{k}: {v:.2f} ms, margin {r['margin_at_1_Hz'][k]:.0f}x at 1 Hz"
                          for k, v in r["time_per_call_ms"].items()))
    write_json("export_cycles", {"flags": list(ARM_FLAGS), "results": results})
    save_figure(plot(results), "export_cycles")


if __name__ == "__main__":
    main()
