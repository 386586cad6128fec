"""Plots of a run: planned vs measured path and joint angles (matplotlib, optional)."""

from __future__ import annotations

import numpy as np

from robodcn.errors import InputError


def _require_matplotlib() -> None:
    try:
        import matplotlib  # noqa: F401
    except ImportError:
        raise InputError("--plot needs matplotlib: pip install 'robodcn[plot]'",
                         field="plot") from None


def _plot(path: str, arm, traj, samples: list[tuple[float, tuple[int, ...]]]) -> None:
    """Planned vs measured end-effector path (left) and joint angles over time (right)."""
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    from robodcn import kinematics, servo_units

    fig, (ax_path, ax_joints) = plt.subplots(1, 2, figsize=(12, 5))
    ax_path.plot(traj.poses[:, 0], traj.poses[:, 1], "-", color="tab:blue", label="planned")
    if samples:
        t_meas = np.array([s[0] for s in samples])
        q_meas = servo_units.ticks_to_radians(np.array([s[1] for s in samples]),
                                              [j.servo for j in arm.joints])
        p_meas = kinematics.fk(arm.links, q_meas)
        ax_path.plot(p_meas[:, 0], p_meas[:, 1], ".", color="tab:orange", ms=3,
                     label="measured")
    ax_path.set(xlabel="x [m]", ylabel="y [m]", title="end-effector path", aspect="equal")
    ax_path.legend()
    for k, name in enumerate(traj.joint_names):
        line, = ax_joints.plot(traj.t, np.degrees(traj.joints[:, k]), label=f"{name} planned")
        if samples:
            ax_joints.plot(t_meas, np.degrees(q_meas[:, k]), ".", ms=3, color=line.get_color(),
                           label=f"{name} measured")
    ax_joints.set(xlabel="t [s]", ylabel="angle [°]", title="joint angles")
    ax_joints.legend(fontsize="small")
    fig.tight_layout()
    fig.savefig(path, dpi=110)
    plt.close(fig)
