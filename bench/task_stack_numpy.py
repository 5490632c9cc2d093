"""The task-priority recursion of skin-control's TaskStack (damped and activation-aware modes) in numpy,
on the problems `cargo bench -p skin-control --bench task_stack` wrote to target/bench-data: checks
it gives the same joint velocities, then times it, and writes target/bench-data/numpy_task_stack.json.

    pip install numpy
    OMP_NUM_THREADS=1 python3 bench/task_stack_numpy.py
"""

import json
import os
import timeit

import numpy as np

folder = os.path.join(os.path.dirname(__file__), "..", "target", "bench-data")


def solve(tasks, lam, n=7):
    p = np.eye(n)
    r = np.zeros(n)
    for jac, rho, a in tasks:
        x = jac @ p
        g = (a * a) * (x @ x.T) + lam * lam * np.eye(x.shape[0])
        pinv = (a * a) * x.T @ np.linalg.inv(g)
        r = r + p @ (pinv @ (rho - jac @ r))
        p = p - p @ (pinv @ x)
        p = 0.5 * (p + p.T)
    return r


def bell(s, peak, threshold):
    return 0.0 if threshold <= 0.0 or s >= threshold else peak * 0.5 * (1.0 + np.cos(np.pi * s / threshold))


def solve_aware(tasks, lam, threshold, eta, n=7):
    """Simetti and Casalino's regularised pseudo-inverse, always through the eigen-decomposition."""
    p = np.eye(n)
    r = np.zeros(n)
    for jac, rho, a in tasks:
        a = min(a, 1.0)
        x = jac @ p
        iq = np.eye(n) - p
        m = a * x.T @ x + eta * iq.T @ iq
        m = 0.5 * (m + m.T)
        s, v = np.linalg.eigh(m)
        d = np.array([1.0 / (max(si, 0.0) + bell(max(si, 0.0), lam * lam, threshold)) for si in s])
        pinv = (v * d) @ v.T @ x.T * (a * a)
        r = r + p @ (pinv @ (rho - jac @ r))
        p = p - p @ (pinv @ x)
        p = 0.5 * (p + p.T)
    return r


out = {}
for count in [2, 5, 8]:
    data = json.load(open(os.path.join(folder, f"task_stack_{count}.json")))
    tasks = [(np.array(t["J"]), np.array(t["rho"]), t["a"]) for t in data["tasks"]]
    q = solve(tasks, data["lambda"])
    diff = float(np.abs(q - np.array(data["qdot"])).max())
    assert diff < 1e-9, f"{count} tasks: numpy and skin differ by {diff}"
    runs = 2000
    best = min(timeit.repeat(lambda: solve(tasks, data["lambda"]), number=runs, repeat=5)) / runs
    aw = data["aware"]
    qa = solve_aware(tasks, aw["lambda"], aw["threshold"], aw["eta"])
    diff_a = float(np.abs(qa - np.array(aw["qdot"])).max())
    assert diff_a < 1e-9, f"{count} tasks, activation-aware: numpy and skin differ by {diff_a}"
    best_a = min(timeit.repeat(lambda: solve_aware(tasks, aw["lambda"], aw["threshold"], aw["eta"]), number=runs // 4, repeat=5)) / (runs // 4)
    out[str(count)] = {"us": best * 1e6, "max_diff": diff, "aware_us": best_a * 1e6, "aware_max_diff": diff_a}
    print(f"{count} tasks: damped {best * 1e6:.1f} us (same result within {diff:.1e}), activation-aware {best_a * 1e6:.1f} us (within {diff_a:.1e})")
json.dump(out, open(os.path.join(folder, "numpy_task_stack.json"), "w"), indent=1)
