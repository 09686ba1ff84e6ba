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
