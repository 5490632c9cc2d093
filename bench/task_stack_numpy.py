"""The task-priority recursion of skin-control's TaskStack (damped least squares mode) in numpy,
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


out = {}
for count in [2, 5, 8]:
    data = json.load(open(os.path.join(folder, f"task_stack_{count}.json")))
    tasks = [(np.array(t["J"]), np.array(t["rho"]), t["a"]) for t in data["tasks"]]
    q = solve(tasks, data["lambda"])
    diff = float(np.abs(q - np.array(data["qdot"])).max())
    assert diff < 1e-9, f"{count} tasks: numpy and skin differ by {diff}"
    runs = 2000
    best = min(timeit.repeat(lambda: solve(tasks, data["lambda"]), number=runs, repeat=5)) / runs
    out[str(count)] = {"us": best * 1e6, "max_diff": diff}
    print(f"{count} tasks: {best * 1e6:.1f} us (same result within {diff:.1e})")
json.dump(out, open(os.path.join(folder, "numpy_task_stack.json"), "w"), indent=1)
