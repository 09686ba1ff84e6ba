"""An exact discrete fixed-priority schedule of small integer transactions, the brute force
the transaction and suspension-aware analyses are checked against."""

from __future__ import annotations

from rtsim.analysis.transaction import Transaction


def brute(
    transactions: list[Transaction], phases: list[int], choose, horizon: int
) -> dict[str, int]:
    """Largest response from arrival of each task's jobs arriving in [0, horizon), in unit
    steps: fixed priority, preemptive, a task's jobs first in, first out, each job's chain in
    order (chains start and end with compute; compute lengths >= 1, suspensions >= 0).
    ``choose(i, n, job)`` gives (release delay, [segment length, ...]) of the job in the n-th
    activation of transaction i, which is activated at phases[i] + n·T_i."""
    queues: dict[str, list[dict]] = {}
    for i, tx in enumerate(transactions):
        n = 0
        while phases[i] + n * tx.period < horizon:
            for job in tx.jobs:
                arr = phases[i] + n * int(tx.period) + int(job.arrival)
                delay, lens = choose(i, n, job)
                queues.setdefault(job.task, []).append(
                    {
                        "prio": job.priority,
                        "arr": arr,
                        "ready": arr + delay,
                        "lens": list(lens),
                        "kinds": [s.kind for s in job.segments],
                        "seg": 0,
                        "done": None,
                    }
                )
            n += 1
    for q in queues.values():
        q.sort(key=lambda j: j["arr"])
    heads = {k: 0 for k in queues}
    t = 0
    while any(heads[k] < len(q) for k, q in queues.items()):
        live = [queues[k][heads[k]] for k in queues if heads[k] < len(queues[k])]
        live = [j for j in live if j["ready"] <= t]
        run = min(
            (j for j in live if j["kinds"][j["seg"]] == "compute"),
            key=lambda j: j["prio"],
            default=None,
        )
        for j in live:
            if j is not run and j["kinds"][j["seg"]] != "suspend":
                continue
            j["lens"][j["seg"]] -= 1
            while j["seg"] < len(j["lens"]) and j["lens"][j["seg"]] == 0:
                j["seg"] += 1
                j["ready"] = t + 1
            if j["seg"] == len(j["lens"]):
                j["done"] = t + 1
        for k, q in queues.items():
            while heads[k] < len(q) and q[heads[k]]["done"] is not None:
                heads[k] += 1
        t += 1
        if t > 50 * horizon:
            raise AssertionError("brute force does not finish")
    out: dict[str, int] = {}
    for k, q in queues.items():
        for j in q:
            if j["arr"] < horizon:
                out[k] = max(out.get(k, 0), j["done"] - j["arr"])
    return out


def brute_srp(
    tasks: list[dict], horizon: int, *, by: str = "deadline", protocol: str = "srp"
) -> dict[str, int]:
    """Largest response of each task's jobs arriving in [0, horizon), in unit steps, under
    EDF (``by="deadline"``) or fixed priority (``"priority"``) with shared resources, as
    Baker (1991) states the stack resource policy: a job that has not started may start
    only if it comes first among the active jobs (deadline, then arrival, then priority)
    and its preemption level is above the system ceiling; of the jobs allowed to run, the
    first runs. A job locks a section's resource when it runs the section's first unit.
    ``tasks``: dicts of name, C, T, D, offset, prio and sections [(resource, start,
    length)] with integer times; levels −D (``deadline``) or −prio; ceilings the highest
    level of a resource's users (``npr``: above every level)."""
    level = {t["name"]: -(t["D"] if by == "deadline" else t["prio"]) for t in tasks}
    ceil: dict[str, float] = {}
    for t in tasks:
        for r, _, _ in t["sections"]:
            lv = float("inf") if protocol == "npr" else level[t["name"]]
            ceil[r] = max(ceil.get(r, -float("inf")), lv)
    jobs = []
    for t in tasks:
        k = 0
        while t["offset"] + k * t["T"] < horizon:
            a = t["offset"] + k * t["T"]
            jobs.append({"t": t, "arr": a, "dl": a + t["D"], "done": 0, "fin": None, "k": k})
            k += 1

    def order(j: dict) -> tuple:
        key = j["dl"] if by == "deadline" else j["t"]["prio"]
        return (key, j["arr"], j["t"]["prio"])

    def holding(j: dict) -> str | None:
        for r, s, n in j["t"]["sections"]:
            if s < j["done"] < s + n:
                return r
        return None

    t = 0
    while any(j["fin"] is None for j in jobs):
        heads = {}
        for j in jobs:  # a task's jobs one at a time, in arrival order
            name = j["t"]["name"]
            if j["fin"] is None and j["arr"] <= t and name not in heads:
                heads[name] = j
        active = sorted(heads.values(), key=order)
        held = [holding(j) for j in active]
        system = max((ceil[r] for r in held if r is not None), default=-float("inf"))
        allowed = [j for j in active if j["done"] > 0]
        if active and active[0]["done"] == 0 and level[active[0]["t"]["name"]] > system:
            allowed.append(active[0])
        if allowed:
            run = min(allowed, key=order)
            run["done"] += 1
            if run["done"] == run["t"]["C"]:
                run["fin"] = t + 1
        t += 1
        if t > 50 * horizon:
            raise AssertionError("brute force does not finish")
    out: dict[str, int] = {}
    for j in jobs:
        name = j["t"]["name"]
        out[name] = max(out.get(name, 0), j["fin"] - j["arr"])
    return out
