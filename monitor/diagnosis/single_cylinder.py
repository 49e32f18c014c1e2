"""A single cylinder's verdict: its strength against its baseline's, read at the load stated or not.

A one-cylinder engine has no others to be compared with, so its strength is judged against its
baseline's (or, without one, the model's) at a load
(:func:`monitor.diagnosis.findings.single_cylinder_findings` holds the rule).  The load is what this
module weighs: at a load nobody stated (the baseline's is assumed) a cylinder that reads weaker and
one at a lower load read alike, as do a stronger one and a higher load.  A weaker reading is then
left undecided (the recording inconclusive: a misfire is never reported healthy), a stronger one is
said in a note with no finding (a higher load is the likelier reading, and no fault the crank speed
shows makes a cylinder stronger); an alarm-sized loss (below a fifth of the rated firing) is no load
a running engine is set to, and stays a finding.
"""

from __future__ import annotations

from monitor.diagnosis.balance import CylinderBalance
from monitor.diagnosis.baseline import Baseline
from monitor.diagnosis.findings import Finding, single_cylinder_findings

__all__ = ["single_cylinder_verdict"]


def single_cylinder_verdict(
    balance: CylinderBalance,
    baseline: Baseline | None,
    load: float | None,
    notes: list[str],
    undecided: list[str],
) -> list[Finding]:
    """The single cylinder's findings at the load stated, else at the baseline's (or rated) load.

    Parameters
    ----------
    balance : CylinderBalance
        The one cylinder's strength from the crank-speed orders.
    baseline : Baseline or None
        The engine's baseline at the recording's point, if calibrated.
    load : float or None
        The load stated [-] (None: none stated).
    notes : list of str
        Appended to: what the cylinder is judged against, or why a reading is no finding.
    undecided : list of str
        Appended to: a weaker reading at a load nobody stated (the recording is inconclusive).

    Returns
    -------
    list of Finding
    """
    single = (
        # a calibrated model gives the strength against the baseline's directly
        (1.0 if baseline.crank is not None and baseline.crank.orders.size else float(baseline.strengths[0]))
        if baseline is not None and len(baseline.strengths) == 1
        else None
    )
    at = load if load is not None else (baseline.load if baseline is not None else 1.0)
    findings = single_cylinder_findings(balance, at, single)
    against = f"its baseline's at the baseline's load {at:.2f}" if single is not None else "the model's"
    # an alarm (below a fifth of the model's rated firing) is no load a running engine is set to
    if load is None and findings and findings[0].severity == "warning":
        measured = round(100 * float(findings[0].evidence[0]["measured"]))
        if float(balance.strength[0]) < 1.0:
            undecided.append(
                f"cylinder 1 reads {measured} % of {against} and no load was stated: a single "
                "cylinder's weaker firing and a lower load read alike; state the load set (--load)"
                + ("" if single is not None else " or compare against a baseline")
            )
        else:
            notes.append(
                f"cylinder 1 reads {measured} % of {against} and no load was stated: a higher load "
                "than that reads alike, and no fault the crank speed shows makes a cylinder stronger, "
                "so it is no finding; state the load set (--load) to judge it"
            )
        return []
    notes.append(
        "a single cylinder is judged against the load "
        + (
            f"stated ({load:.2f})"
            if load is not None
            else f"{'of its baseline' if baseline is not None else 'rated'}, none stated"
        )
        + ": state the load set (the fuel or the governor's setting), not the power delivered, or a "
        "weak cylinder reads as a lower load"
    )
    return findings
