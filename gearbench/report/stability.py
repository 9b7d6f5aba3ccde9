"""Reports of ``gearbench stability``: Markdown and a rich table."""
from __future__ import annotations

from ..control.controllers import KIND_NAMES


def _range(iv) -> str:
    high = "inf" if iv.high is None else f"{iv.high:.6g}"
    return f"{iv.low:.6g} < Kp < {high} V/deg"


def describe_controller(rep) -> str:
    text = KIND_NAMES[rep.kind]
    if rep.kind in ("pi", "pid"):
        text += f", Ki = {rep.ki:g} 1/s"
    if rep.kind == "pid":
        text += f", Kd = {rep.kd:g} s, Tf = {rep.tf:g} s"
    return text


def stability_markdown(rep, command: str = "") -> str:
    """Stable gain range(s), how each end was found, and the eigenvalue cross-check."""
    scan = rep.to_dict()["eigen_scan"]
    lines = [f"## Closed-loop stability: {describe_controller(rep)} on `{rep.plant}` (engaged, "
             f"linear, saturation ignored)", ""]
    if command:
        lines += [f"Command: `{command}`", ""]
    lines += [f"States: {', '.join(rep.states)}; characteristic polynomial of degree "
              f"{len(rep.den) - 1} in s, affine in K = Kp 180/pi (V/rad).", ""]
    if rep.intervals:
        for iv in rep.intervals:
            ends = []
            if iv.low_by:
                ends.append(f"lower end where {iv.low_by} = 0")
            if iv.high_by:
                ends.append(f"upper end where {iv.high_by} = 0")
            lines.append(f"- **Routh-Hurwitz: stable for {_range(iv)}**"
                         + (f" ({'; '.join(ends)})" if ends else ""))
    else:
        lines.append("- **Routh-Hurwitz: stable for no Kp > 0**")
    lines.append(f"- Eigenvalue cross-check: {scan['points']} gains log-spaced over "
                 f"{scan['kp_min']:g} ... {scan['kp_max']:g} V/deg; the verdicts agree at "
                 f"{scan['agree']} of {scan['points']}"
                 + (f" (differ at {', '.join(f'{k:.4g}' for k in scan['disagree_kp'])})"
                    if scan["disagree_kp"] else "") + ".")
    free = " or ".join(_range(iv) for iv in rep.free_intervals) or "no Kp > 0"
    lines.append(f"- Teeth apart (motor alone inside the clearance, same controller): stable for "
                 f"{free} (eigenvalues agree at {rep.free_scan_agrees} of {scan['points']}).")
    if rep.rigid_bound is not None:
        lines.append(f"- Rigid-gear approximation (third-order loop, no mesh compliance): "
                     f"Kp < {rep.rigid_bound:.6g} V/deg.")
    lines += ["", "| Kp (V/deg) | RHP roots, Routh array | RHP roots, eigenvalues "
                  "| largest Re(eigenvalue) (1/s) | dominant pair: damping ratio, Hz | teeth apart: "
                  "largest Re(eigenvalue) (1/s) |", "|---:|---:|---:|---:|---:|---:|"]
    for c in rep.checks:
        routh = "zero in first column" if c["rhp_roots_routh"] is None else str(c["rhp_roots_routh"])
        zeta = "" if c["dominant_damping_ratio"] is None else \
            f"{c['dominant_damping_ratio']:.3g}, {c['dominant_frequency_hz']:.4g}"
        lines.append(f"| {c['kp']:g} | {routh} | {c['rhp_roots_eig']} | {c['max_real_eig']:.4g} "
                     f"| {zeta} | {c['max_real_eig_teeth_apart']:.4g} |")
    return "\n".join(lines) + "\n"


def rich_table(rep):
    from rich.table import Table

    t = Table(title=f"{describe_controller(rep)} on {rep.plant}: engaged, linear, no saturation")
    for col in ("Kp V/deg", "RHP roots Routh", "RHP roots eig", "max Re(eig) 1/s", "zeta",
                "verdict", "teeth apart max Re 1/s"):
        t.add_column(col, justify="right")
    for c in rep.checks:
        routh = "zero" if c["rhp_roots_routh"] is None else str(c["rhp_roots_routh"])
        stable = c["rhp_roots_routh"] == 0 and c["max_real_eig"] < 0
        zeta = "" if c["dominant_damping_ratio"] is None else f"{c['dominant_damping_ratio']:.3g}"
        t.add_row(f"{c['kp']:g}", routh, str(c["rhp_roots_eig"]), f"{c['max_real_eig']:.4g}", zeta,
                  "stable" if stable else "unstable", f"{c['max_real_eig_teeth_apart']:.4g}")
    return t
