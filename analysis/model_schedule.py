#!/usr/bin/python3
"""How fast could the model engine's regions run on 2 ranks, and how fast did
this run's schedule run them, counted in the regions' own CPU seconds (no
waiting for a core, so a machine shared with other jobs does not move it)?

    model_schedule.py RUN_DIR [--check]

Reads RUN_DIR/schedule.jsonl (written with model.schedule_log = true: per
region run the window, pass, id, colour, the rank that ran it, its place in
that rank's order (seq), its CPU seconds (cpu_s) and the ids it waited for
(waits_for: the interacting regions of lower colours), and its tries
(attempts) and backtracks). A window ends with every rank done, so figures add
up over windows. Per window:
  crit     the longest chain of regions that wait for each other
  bound2   max(crit, cpu / 2): no 2-rank schedule is shorter
  policy2  src/par/regions_flow.c's pick rule on 2 ranks (position k in the
           window; a free rank takes, of the ready regions with k mod 2 its own
           and, while the other rank is busy, the other rank's, the one most
           regions wait for directly or through others, then the lowest k),
           message latency 0
  replay   each rank runs the regions this run gave it in the order it ran
           them, each once its rank is free and what it waits for is done
Prints JSON: cpu, crit and the speed-ups cpu / bound2, cpu / policy2,
cpu / replay. --check: compare with RUN_DIR/summary.json's schedule_* metrics
(the engine's own computation of the same figures) and exit 1 on a mismatch.
"""
import json
import sys


def read(path):
    wins = {}
    for line in open(path):
        r = json.loads(line)
        wins.setdefault(r["window"], []).append(
            {"id": r["id"], "rank": r["rank"], "seq": r["seq"], "cpu": r["cpu_s"],
             "preds": r["waits_for"]})
    return [wins[k] for k in sorted(wins)]


def dependents(succ):
    """Per region, how many regions wait for it, directly or through others
    (regions_flow.c's priority)."""
    out = []
    for i in range(len(succ)):
        seen, stack = set(), list(succ[i])
        while stack:
            j = stack.pop()
            if j not in seen:
                seen.add(j)
                stack.extend(succ[j])
        out.append(len(seen))
    return out


def window_figures(regs):
    regs = sorted(regs, key=lambda r: r["id"])
    pos = {r["id"]: i for i, r in enumerate(regs)}
    n = len(regs)
    d = [r["cpu"] for r in regs]
    preds = [[pos[p] for p in r["preds"]] for r in regs]
    for i, ps in enumerate(preds):
        assert all(p < i for p in ps), "a region waits for a later one"
    fin = [0.0] * n
    for i in range(n):
        fin[i] = max((fin[p] for p in preds[i]), default=0.0) + d[i]
    crit, cpu = max(fin), sum(d)
    # the dataflow's pick rule on 2 ranks
    succ = [[] for _ in range(n)]
    for i, ps in enumerate(preds):
        for p in ps:
            succ[p].append(i)
    key = [(-d, i) for i, d in enumerate(dependents(succ))]
    npend = [len(ps) for ps in preds]
    ready = [0.0] * n
    done = [False] * n
    fin = [0.0] * n
    free = [0.0, 0.0]
    left = n
    while left:
        r = 1 if free[1] < free[0] else 0
        t = free[r]
        cand = [i for i in range(n) if not done[i] and npend[i] == 0 and ready[i] <= t]
        if free[0] == free[1]:  # both free: rank 0 first, unless only rank 1's regions are ready
            r = 1 if cand and all(i % 2 == 1 for i in cand) else 0
        pool = [i for i in cand if i % 2 == r or free[1 - r] > t]
        k = min(pool, key=lambda i: key[i]) if pool else None
        if k is None:
            later = [fin[i] for i in range(n) if done[i] and fin[i] > t]
            later += [ready[i] for i in range(n) if not done[i] and npend[i] == 0 and ready[i] > t]
            if free[1 - r] > t:
                later.append(free[1 - r])
            free[r] = min(later)
            continue
        done[k] = True
        fin[k] = t + d[k]
        free[r] = fin[k]
        left -= 1
        for s in succ[k]:
            npend[s] -= 1
            ready[s] = max(ready[s], fin[k])
    policy2 = max(fin)
    # this run's assignment and order
    queues = {}
    for i, r in enumerate(regs):
        queues.setdefault(r["rank"], []).append((r["seq"], i))
    for q in queues.values():
        q.sort()
    done = [False] * n
    free = {q: 0.0 for q in queues}
    left, moved = n, True
    while left and moved:
        moved = False
        for q, lst in queues.items():
            while lst:
                i = lst[0][1]
                if not all(done[p] for p in preds[i]):
                    break
                fin[i] = max([free[q]] + [fin[p] for p in preds[i]]) + d[i]
                free[q] = fin[i]
                done[i] = True
                lst.pop(0)
                left -= 1
                moved = True
    assert left == 0, "this run's order is not one the waits allow"
    replay = max(fin)
    return cpu, crit, max(crit, cpu / 2), policy2, replay


def main():
    args = [a for a in sys.argv[1:] if not a.startswith("--")]
    if len(args) != 1:
        sys.exit(__doc__)
    run = args[0]
    tot = [0.0] * 5
    wins = read(run + "/schedule.jsonl")
    for regs in wins:
        for a, v in enumerate(window_figures(regs)):
            tot[a] += v
    cpu, crit, bound2, policy2, replay = tot
    out = {"windows": len(wins), "regions": sum(len(w) for w in wins),
           "schedule_region_cpu_seconds": cpu, "schedule_critical_path_seconds": crit,
           "schedule_speedup_bound_2ranks": cpu / bound2,
           "schedule_speedup_policy_2ranks": cpu / policy2,
           "schedule_speedup_replay": cpu / replay}
    bad = []
    if "--check" in sys.argv:
        m = json.load(open(run + "/summary.json"))["metrics"]
        for k, v in out.items():
            if k.startswith("schedule_") and abs(m.get(k, -1) - v) > 1e-6 * max(1.0, abs(v)):
                bad.append(f"{k}: engine {m.get(k)} vs recomputed {v}")
        out["check"] = "ok" if not bad else bad
    print(json.dumps(out, indent=1))
    sys.exit(1 if bad else 0)


if __name__ == "__main__":
    main()
