"""The pHRI scene: an arm that carries the skin follows a path, and the gate's action decides
whether it goes on (thesis Ch. 9.2, experiment 2: path following as the low priority task, a touch
handled as the classifier says).

`two_joint_arm` builds a planar arm (a shoulder and an elbow turning about the vertical) whose
forearm is a link of the skin; `PathFollower` is its controller, called at every control step
with the `SkinLoop`:

| gate          | the arm                                                                 |
|---------------|-------------------------------------------------------------------------|
| none, resume  | follows the path at its pace                                            |
| slow          | follows it at half its pace                                             |
| stop          | stops where it is and holds there, stiff                                |
| comply        | stops following and yields: held where it is with a tenth of the gains  |

so that with the fixture session's gate (hand -> comply, non_hand -> stop) a hand on the arm halts
the path and lets the person move the arm, and an object halts it stiffly; the path resumes when
the touch is released.
"""

from __future__ import annotations

from typing import Callable, Optional, Sequence

import numpy as np

from .._errors import ArrayError, UnknownNameError
from .bridge import _mujoco, check_timestep

#: The position servos' stiffness (N m / rad) and damping (N m s / rad).
ARM_KP = 200.0
ARM_KV = 20.0

#: How the path's pace follows the gate.
PACE = {None: 1.0, "resume": 1.0, "slow": 0.5, "stop": 0.0, "comply": 0.0}


def two_joint_arm(link: str, *, upper: float = 0.3, timestep: float = 0.002):
    """A `mujoco.MjSpec`: a shoulder at the origin and an elbow `upper` metres along x, both
    turning about z, and the skin's link `link` on the forearm body of that name (its frame at
    the elbow, the fixture forearm's axis along y, its top up). Both joints turn about the
    vertical, so gravity does not load them. `timestep`: seconds, as `bare_robot` takes it."""
    mujoco = _mujoco()
    spec = mujoco.MjSpec()
    spec.option.timestep = check_timestep(timestep)
    shoulder = spec.worldbody.add_body(name="upper_arm")
    shoulder.add_joint(name="shoulder", type=mujoco.mjtJoint.mjJNT_HINGE, axis=[0, 0, 1])
    g = shoulder.add_geom(name="upper_arm", type=mujoco.mjtGeom.mjGEOM_CAPSULE, fromto=[0, 0, 0, upper, 0, 0], size=[0.04, 0, 0])
    g.mass = 2.0
    forearm = shoulder.add_body(name=link, pos=[upper, 0, 0])
    forearm.add_joint(name="elbow", type=mujoco.mjtJoint.mjJNT_HINGE, axis=[0, 0, 1])
    # The forearm's own mass where its skin is; the skin's cover is what touches.
    core = forearm.add_geom(name=f"{link}_core", type=mujoco.mjtGeom.mjGEOM_CAPSULE, fromto=[0, 0.02, 0, 0, 0.34, 0], size=[0.03, 0, 0])
    core.mass = 1.5
    core.contype = 0
    core.conaffinity = 0
    for joint in ("shoulder", "elbow"):
        a = spec.add_actuator(name=joint, target=joint, trntype=mujoco.mjtTrn.mjTRN_JOINT)
        a.set_to_position(kp=ARM_KP, kv=ARM_KV)
    return spec


class PathFollower:
    """Follows `path(s)` (joint angles, rad, of the path parameter s in seconds) with the position
    servos `actuators`, at the pace the gate allows (see the module's table)."""

    def __init__(self, model, data, actuators: Sequence[str], path: Callable[[float], np.ndarray]) -> None:
        mujoco = _mujoco()
        self.model, self.data = model, data
        self.path = path
        self.ids = [mujoco.mj_name2id(model, mujoco.mjtObj.mjOBJ_ACTUATOR, a) for a in actuators]
        missing = [a for a, i in zip(actuators, self.ids) if i < 0]
        if missing:
            raise UnknownNameError(f"no actuator {missing[0]!r} in the model")
        for a, i in zip(actuators, self.ids):
            # A position servo: force = kp (ctrl - q) - kv qdot, on one joint.
            servo = (
                model.actuator_trntype[i] == mujoco.mjtTrn.mjTRN_JOINT
                and model.actuator_biastype[i] == mujoco.mjtBias.mjBIAS_AFFINE
                and abs(model.actuator_biasprm[i, 1] + model.actuator_gainprm[i, 0]) < 1e-12
            )
            if not servo:
                raise ArrayError(f"actuator {a!r} is not a position servo on a joint (set_to_position)")
        self.joints = [int(model.actuator_trnid[a, 0]) for a in self.ids]
        self.kp = np.array([model.actuator_gainprm[a, 0] for a in self.ids])
        self.kv = np.array([-model.actuator_biasprm[a, 2] for a in self.ids])
        #: Where along the path the arm is (seconds of path).
        self.s = 0.0
        self.held: Optional[np.ndarray] = None
        self.gate: Optional[str] = None

    def q(self) -> np.ndarray:
        return np.array([self.data.qpos[self.model.jnt_qposadr[j]] for j in self.joints])

    def restore(self) -> None:
        """The servos' own gains back (complying lowers them while a hand is on the arm)."""
        for a, kp, kv in zip(self.ids, self.kp, self.kv):
            self.model.actuator_gainprm[a, 0] = kp
            self.model.actuator_biasprm[a, 1] = -kp
            self.model.actuator_biasprm[a, 2] = -kv

    def __call__(self, loop) -> None:
        self.gate = loop.gate
        pace = PACE.get(self.gate, 0.0)
        soft = 0.1 if self.gate == "comply" else 1.0
        for a, kp, kv in zip(self.ids, self.kp, self.kv):
            self.model.actuator_gainprm[a, 0] = kp * soft
            self.model.actuator_biasprm[a, 1] = -kp * soft
            self.model.actuator_biasprm[a, 2] = -kv * soft
        if pace == 0.0:
            if self.held is None:
                self.held = self.q()
            target = self.held
        else:
            if self.held is not None:
                # The path goes on from where it stopped; the servos pull the arm back onto it
                # from wherever the touch left it.
                self.held = None
            self.s += pace * self.model.opt.timestep
            target = self.path(self.s)
        for a, q in zip(self.ids, target):
            self.data.ctrl[a] = q
