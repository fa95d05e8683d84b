"""Issue #13's targets, all measured in one run on one machine.

    python3 bench/issue13/targets.py [--rounds 9] [--certify-runs 11] [--scipy-runs 3]
                                     [--work /tmp/issue13] [--out FILE]

What it does, in this order (the 1-minute load average is written next to every phase):

1. **Builds** two release trees in `--work` with their own target directories: *base*, the
   issue's baseline (commit 47a60f5, faer's general sparse LU) with
   `bench/issue13/base_newton_step.patch` (the `bvp::NewtonStep` hook, which main has), and
   *head*, a clean checkout of this repository's HEAD (uncommitted changes are not measured).
   `bench/issue13/step_ab.rs` is main's example `step_ab` (Cargo.toml; `cargo test` builds it,
   so it keeps compiling) and is copied into the baseline's `examples/`; head's `suslov`
   binary is built too.
2. **One Newton step** on the final mesh of each paper case: `step_ab` of base and head in
   alternated fresh processes (`--rounds` rounds, the order swapped every round). Medians of
   the thread CPU time per step (and wall), the ratio of the medians, and the median of the
   per-round ratios. Target: base / head >= 4 on both meshes.
3. **The certificate**: `suslov -q --json certify` (both cases in one process) and
   `suslov -q --json certify examples/paper_eta{1,0.01}.toml` (one case, fresh process),
   `--certify-runs` times each, alternated; the median of certificate / solve per case and
   mode, and the verdicts. Target: <= 1 everywhere.
4. **Where `suslov paper` spends its time**: `perf record` (flat, self time) over five runs,
   the symbols grouped into the linear algebra of the Newton steps (condensation, structured
   factorization and solves, faer), the generated model, figures and PNG, and the rest. Target
   (issue's "done when"): the linear algebra no longer dominates. Skipped without `perf`.
5. **Side by side with scipy**: `bench/scipy_paper.py --runs S --ours-runs 2S + 1 --binary
   head's suslov` (its own alternation of scipy's pipeline and ours), its output included.
   Targets: solves >= 200x, the whole `suslov paper` >= 100x.

The report (Markdown) goes to standard output and to `--out` (default WORK/report.md);
progress goes to standard error. Nothing here asserts a time: it measures and says which
target each number meets.
"""

import argparse
import json
import os
import re
import shutil
import statistics
import subprocess
import sys
import time

REPO = os.path.dirname(os.path.dirname(os.path.dirname(os.path.abspath(__file__))))
BASE_REV = "47a60f5446e0c4c4117e1fc0cdb43d58ba2d4169"
CASES = [("eta_1", 1.0, "examples/paper_eta1.toml"),
         ("eta_0.01", 0.01, "examples/paper_eta0.01.toml")]


def say(*a):
    print(*a, file=sys.stderr, flush=True)


def load():
    with open("/proc/loadavg") as f:
        return float(f.read().split()[0])


def run(cmd, **kw):
    """Run `cmd`, fail loudly with its output if it fails."""
    p = subprocess.run(cmd, capture_output=True, text=True, **kw)
    if p.returncode != 0:
        raise SystemExit(f"{' '.join(cmd)} failed ({p.returncode}):\n{p.stdout}\n{p.stderr}")
    return p.stdout


def prepare(work, name, rev, patch):
    """A worktree of `rev` at WORK/name (patched, with step_ab), built; its target dir."""
    tree = os.path.join(work, name)
    target = os.path.join(work, f"target-{name}")
    if not os.path.isdir(tree):
        run(["git", "-C", REPO, "worktree", "add", "--detach", "-q", tree, rev])
        if patch:
            run(["git", "-C", tree, "apply", os.path.join(REPO, "bench/issue13", patch)])
    elif not patch:
        run(["git", "-C", tree, "checkout", "-q", "--detach", rev])  # a later HEAD
    if patch:  # main declares the example in Cargo.toml; the baseline gets a copy
        shutil.copy(os.path.join(REPO, "bench/issue13/step_ab.rs"),
                    os.path.join(tree, "examples/step_ab.rs"))
    say(f"building {name} ({rev[:12]}) in {tree} ...")
    t = time.perf_counter()
    env = dict(os.environ, CARGO_TARGET_DIR=target)
    run(["cargo", "build", "--release", "--example", "step_ab", "--bin", "suslov"],
        cwd=tree, env=env)
    say(f"  built in {time.perf_counter() - t:.0f} s")
    return tree, os.path.join(target, "release")


def median(v):
    return statistics.median(v)


def steps_phase(bins, rounds):
    """Alternated step_ab runs; {tree: {case: [records]}}."""
    out = {name: {} for name in bins}
    loads = [load()]
    for r in range(rounds):
        order = list(bins) if r % 2 == 0 else list(reversed(list(bins)))
        for name in order:
            for line in run([os.path.join(bins[name], "examples/step_ab")]).splitlines():
                rec = json.loads(line)
                out[name].setdefault(rec["eta"], []).append(rec)
        say(f"  step round {r + 1}/{rounds}, load {load():.2f}")
    loads.append(load())
    return out, loads


def steps_table(res, rounds, loads):
    lines = [f"One Newton step on each paper case's final mesh (`step_ab`, {rounds} alternated "
             f"rounds of fresh processes, load {loads[0]:.2f} -> {loads[1]:.2f}); thread CPU "
             "ms per step, medians (wall in brackets):", "",
             "| case | N | base ms | head ms | base / head | per-round median | "
             "correction norm base / head | target 4x |",
             "|---|---|---|---|---|---|---|---|"]
    met = True
    for _, eta, _ in CASES:
        b, h = res["base"][eta], res["head"][eta]
        bc, hc = median([x["cpu_ms"] for x in b]), median([x["cpu_ms"] for x in h])
        bw, hw = median([x["wall_ms"] for x in b]), median([x["wall_ms"] for x in h])
        per_round = median([x["cpu_ms"] / y["cpu_ms"] for x, y in zip(b, h)])
        ratio = bc / hc
        ok = ratio >= 4 and per_round >= 4
        met &= ok
        lines.append(f"| paper η = {eta:g} | {h[0]['intervals']} | {bc:.2f} ({bw:.2f}) | "
                     f"{hc:.2f} ({hw:.2f}) | **{ratio:.2f}x** | {per_round:.2f}x | "
                     f"{b[0]['correction_norm']:.6e} / {h[0]['correction_norm']:.6e} | "
                     f"{'met' if ok else 'NOT met'} |")
    return lines, met


def scaling_phase(tree, target):
    """Head's `cargo bench --bench bvp -- step`: the step per interval against N and n."""
    l0 = load()
    env = dict(os.environ, CARGO_TARGET_DIR=target)
    outp = run(["cargo", "bench", "-q", "--bench", "bvp", "--", "step"], cwd=tree, env=env)
    l1 = load()
    rows = [line for line in outp.splitlines() if line.startswith("|")]
    osc = [(int(c[2]), float(c[4])) for c in (line.split("|") for line in rows)
           if "oscillators" in c[1]]
    lines = [f"Head's `cargo bench --bench bvp -- step` (wall medians; load {l0:.2f} -> "
             f"{l1:.2f}):", ""] + rows + [""]
    if len(osc) < 2:
        return lines + ["No oscillator rows: flatness not measured."], None
    per = [u for _, u in osc]
    spread = max(per) / min(per)
    lines.append(f"µs per interval, n = 12 oscillators, N = {osc[0][0]} … {osc[-1][0]}: "
                 f"{', '.join(f'{u:.2f}' for u in per)} (max / min {spread:.2f}).")
    return lines, spread


def certify_phase(suslov, runs):
    """{mode: {case: [(certify_s, solve_s, verdict)]}}, loads."""
    modes = [("both cases, one process", [])] + [
        (f"`{path}` alone", [path]) for _, _, path in CASES]
    out = {m: {} for m, _ in modes}
    loads = [load()]
    for r in range(runs):
        for mode, extra in (modes if r % 2 == 0 else list(reversed(modes))):
            rep = json.loads(run([suslov, "-q", "--json", "certify", *extra], cwd=REPO))
            for c in rep["cases"]:
                out[mode].setdefault(c["name"], []).append(
                    (c["certify_seconds"], c["solve_seconds"], c["verdict"]))
        say(f"  certify round {r + 1}/{runs}, load {load():.2f}")
    loads.append(load())
    return out, loads


def certify_table(res, runs, loads):
    lines = [f"`suslov -q --json certify` ({runs} runs of each mode, alternated, load "
             f"{loads[0]:.2f} -> {loads[1]:.2f}); medians:", "",
             "| mode | case | solve s | certificate s | certificate / solve (median per run) | "
             "verdicts | target <= 1 |", "|---|---|---|---|---|---|---|"]
    met = True
    for mode, cases in res.items():
        for case, recs in cases.items():
            c, s = median([x[0] for x in recs]), median([x[1] for x in recs])
            per = median([x[0] / x[1] for x in recs])
            verdicts = sorted({x[2] for x in recs})
            ok = per <= 1 and verdicts == ["certified"]
            met &= ok
            lines.append(f"| {mode} | {case} | {s:.3f} | {c:.3f} | **{per:.3f}** | "
                         f"{', '.join(verdicts)} | {'met' if ok else 'NOT met'} |")
    return lines, met


GROUPS = [
    ("linear algebra of the Newton steps (condensation, structured LU and solves, faer)",
     re.compile(r"bvp::abd|bvp::dense|condense|expand_correction|reduce_residual|"
                r"GlobalSystem|faer|lu_factor|lu_solve|bc_sensitivity")),
    ("generated model (right-hand sides, Jacobians)", re.compile(r"suslov::model::")),
    ("the rest of the solve (residuals, norms, desired path, mesh)",
     re.compile(r"suslov::bvp::|suslov::lie::path|so3::desired|suslov::lie::problem")),
    ("verification (re-integration, interpolation)",
     re.compile(r"differential_equations|eval_parts|suslov::ivp|suslov::reconstruct|"
                r"suslov::lie::verify|so3::reintegrate|so3::stability|lie::collapse")),
    ("figures and PNG", re.compile(r"plotters|png::|fdeflate|ab_glyph|report::figures|"
                                   r"miniz|crc32|adler")),
    ("number formatting (CSV, JSON)", re.compile(r"flt2dec|core::fmt|ryu|serde")),
    ("kernel, allocation and memory copies", re.compile(
        r"^\[k\]|memset|memmove|memcpy|malloc|_int_free|_int_malloc|free$|cfree")),
]


def profile_phase(suslov, work, runs=5):
    if shutil.which("perf") is None:
        return ["`perf` is not installed: the profile was skipped."], None
    data = os.path.join(work, "paper.perf")
    outs = " ".join(os.path.join(work, f"paper-out-{i}") for i in range(runs))
    l0 = load()
    run(["perf", "record", "-q", "-F", "4000", "-o", data, "--", "sh", "-c",
         f"for d in {outs}; do rm -rf $d; {suslov} -q paper --out $d || exit 1; done"],
        cwd=REPO)
    l1 = load()
    rep = run(["perf", "report", "-i", data, "--no-children", "--sort", "sym", "--stdio",
               "--percent-limit", "0"])
    shares, top = {g: 0.0 for g, _ in GROUPS}, []
    other = 0.0
    for line in rep.splitlines():
        m = re.match(r"\s*([\d.]+)%\s+\[[.k]\]\s+(.*)$", line)
        if not m:
            continue
        pct, sym = float(m.group(1)), m.group(2).strip()
        if "[k]" in line:
            sym = "[k] " + sym
        if len(top) < 12:
            top.append((pct, sym))
        for g, rx in GROUPS:
            if rx.search(sym):
                shares[g] += pct
                break
        else:
            other += pct
    lines = [f"`perf record -F 4000` over {runs} runs of `suslov -q paper` (all threads, self "
             f"time; load {l0:.2f} -> {l1:.2f}):", "", "| group | share of samples |",
             "|---|---|"]
    for g, _ in GROUPS:
        lines.append(f"| {g} | {shares[g]:.1f} % |")
    lines += [f"| everything else | {other:.1f} % |", "", "The twelve largest symbols:", "",
              "| self | symbol |", "|---|---|"]
    lines += [f"| {p:.2f} % | `{s[:110]}` |" for p, s in top]
    la = shares[GROUPS[0][0]]
    dominant = max(list(shares.values()) + [other])
    return lines, (la < 50 and la <= dominant, la)


def scipy_phase(suslov, runs):
    l0 = load()
    outp = run([sys.executable, os.path.join(REPO, "bench/scipy_paper.py"), "--runs",
                str(runs), "--ours-runs", str(2 * runs + 1), "--binary", suslov], cwd=REPO)
    l1 = load()
    total = next((line for line in outp.splitlines() if line.startswith("| total |")), None)
    ratios = re.findall(r"\| (\d+)x \|", total or "")
    return outp, [float(r) for r in ratios], (l0, l1)


def main():
    ap = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    ap.add_argument("--rounds", type=int, default=9, help="alternated step rounds")
    ap.add_argument("--certify-runs", type=int, default=11)
    ap.add_argument("--scipy-runs", type=int, default=3, help="0: skip the scipy pipeline")
    ap.add_argument("--work", default="/tmp/issue13")
    ap.add_argument("--out", default=None)
    args = ap.parse_args()
    os.makedirs(args.work, exist_ok=True)
    if args.scipy_runs > 0:
        try:
            import numpy  # noqa: F401
            import scipy  # noqa: F401
        except ImportError as e:
            raise SystemExit(f"{e}: install bench/requirements-scipy.txt first "
                             "(pip install -r bench/requirements-scipy.txt), or pass "
                             "--scipy-runs 0")
    head = run(["git", "-C", REPO, "rev-parse", "HEAD"]).strip()
    t0 = time.strftime("%Y-%m-%d %H:%M UTC", time.gmtime())
    _, base_bin = prepare(args.work, "base", BASE_REV, "base_newton_step.patch")
    _, head_bin = prepare(args.work, "head", head, None)
    suslov = os.path.join(head_bin, "suslov")
    cpu = next((line.split(":", 1)[1].strip() for line in open("/proc/cpuinfo")
                if line.startswith("model name")), "?")
    report = [f"# Issue #13's targets in one run ({t0})", "",
              f"base = {BASE_REV[:7]} (the issue's baseline, with the `NewtonStep` hook), "
              f"head = {head[:7]}; {os.cpu_count()} cores, {cpu}.", ""]
    verdicts = []

    say("phase 1: Newton steps")
    res, loads = steps_phase({"base": base_bin, "head": head_bin}, args.rounds)
    lines, ok = steps_table(res, args.rounds, loads)
    report += ["## One Newton step", ""] + lines + [""]
    verdicts.append(("per Newton step >= 4x the baseline on both paper meshes", ok))

    say("phase 1b: step against N and n (head's bench)")
    lines, spread = scaling_phase(os.path.join(args.work, "head"), os.path.dirname(head_bin))
    report += ["## One Newton step against the mesh size and the state dimension", ""] + lines
    report += [""]
    if spread is not None:
        verdicts.append((f"flat cost per interval, N = 10² … 10⁴ (max / min {spread:.2f} "
                         "<= 1.5)", spread <= 1.5))

    say("phase 2: certificate")
    cres, cloads = certify_phase(suslov, args.certify_runs)
    lines, ok = certify_table(cres, args.certify_runs, cloads)
    report += ["## The certificate against its solve", ""] + lines + [""]
    verdicts.append(("`suslov certify`: certificate <= its solve, each case", ok))

    say("phase 3: profile")
    lines, prof = profile_phase(suslov, args.work)
    report += ["## Where `suslov paper` spends its time", ""] + lines + [""]
    if prof is not None:
        verdicts.append((f"linear algebra no longer dominating `suslov paper` "
                         f"({prof[1]:.1f} % of samples)", prof[0]))

    if args.scipy_runs > 0:
        say("phase 4: scipy pipeline (minutes)")
        try:
            outp, ratios, sl = scipy_phase(suslov, args.scipy_runs)
        except SystemExit as e:
            outp, ratios, sl = f"The scipy pipeline failed: {e}", [], (load(), load())
        report += [f"## Side by side with scipy (`bench/scipy_paper.py`, load {sl[0]:.2f} -> "
                   f"{sl[1]:.2f})", "", outp.rstrip(), ""]
        if len(ratios) == 2:
            verdicts.append((f"solves >= 200x scipy's ({ratios[0]:.0f}x)", ratios[0] >= 200))
            verdicts.append((f"whole `suslov paper` >= 100x scipy's solves ({ratios[1]:.0f}x)",
                             ratios[1] >= 100))
        else:
            verdicts.append(("scipy's table has no total row", False))

    report[4:4] = ["| target | this run |", "|---|---|"] + [
        f"| {t} | {'met' if ok else '**NOT met**'} |" for t, ok in verdicts] + [""]
    text = "\n".join(report) + "\n"
    print(text)
    with open(args.out or os.path.join(args.work, "report.md"), "w") as f:
        f.write(text)


if __name__ == "__main__":
    main()
