"""The hardware-in-the-loop part of a recording's report: the measures of each road
segment, the damper's target against its measured motion, the car around the damper
against the reference (the car around the damper model), and for a sweep the
transmissibility of both; for a replay, the error of each iteration and the last one's
motion against its target."""
from __future__ import annotations

import numpy as np

from records.events import ClosedLoopResult, SegmentStart
from records.data import segment_kind
from models.quarter_car.hil import transmissibility
from protocols.library.replay import RECOVER_S
from views.reports.page import save
from views.reports.plots import plt
from protocols.units import Units

HEADER = ("segment", "compensator", "J2 [%]", "delay [ms]", "probe delay [ms]", "residual delay [ms]",
          "body acc NRMSE [%]", "travel NRMSE [%]", "tire load NRMSE [%]", "damper [C]")


def results(events):
    """[(segment, measures)] of the recording's road segments."""
    return [(e.segment, e.params) for e in events if isinstance(e, ClosedLoopResult) and e.of == "hil"]


# what the table's measures are, said on the page under it (docs/hil.md)
MEANING = ("J2: how far the damper missed the car's wanted motion, RMS(measured - target) over "
           "RMS(target about its mean); delay: the compensator's estimate, the probe's measurement and "
           "what is left of it after compensation (cross-correlation of measured and target). The NRMSEs "
           "compare the car around the real damper with the car around the damper model (the reference), "
           "each normalised as J2: under a few percent, the model stands in for the damper on this road.")
REPLAY_MEANING = ("NRMS error: RMS(measured - target) over RMS(target about its mean) of each iteration; "
                  "each drive is the last one corrected by its error through the rig's measured response. "
                  f"Undisturbed: the same without the ticks within {1e3 * RECOVER_S:g} ms after a stall of the "
                  "control loop, where the actuator caught up with a setpoint that jumped.")
REPLAY_HEADER = ("iteration", "NRMS error [%]", "undisturbed [%]")


def replay_errors(events):
    """[(iteration, NRMS error [-])] of a replay's iterations."""
    return [(e.params["iteration"], e.params["nrmse"]) for e in events if isinstance(e, ClosedLoopResult) and e.of == "replay"]


def replay_table(events):
    """Rows (REPLAY_HEADER) of the replay table; a recording from before the undisturbed
    error was kept shows a dash."""
    return [(e.params["iteration"], f"{100 * e.params['nrmse']:.3f}",
             f"{100 * e.params['nrmse_undisturbed']:.3f}" if "nrmse_undisturbed" in e.params else "-")
            for e in events if isinstance(e, ClosedLoopResult) and e.of == "replay"]


def table(events):
    """Rows of the measures table (HEADER)."""
    return [(name, m.get("compensator", "?"), f"{100 * m['j2']:.2f}", f"{m['delay_ms']:.2f}",
             f"{m['probe_delay_ms']:.2f}", f"{m['residual_delay_ms']:+.2f}", f"{100 * m['body_acc_nrmse']:.2f}",
             f"{100 * m['travel_nrmse']:.2f}", f"{100 * m['tire_load_nrmse']:.2f}", f"{m['T_c']:.1f}")
            for name, m in results(events)]


def figures(ch, events, out, units=Units()):
    """[(title, png)] of the road segments' plots, in `units`."""
    if "replay.target" in ch:
        return _replay(ch, events, out, units)
    found = results(events)
    if not found or "hil.x_target" not in ch:
        return []
    figs = [("Damper motion: where the car wants it and where it was", save(_tracking(ch, units), out / "hil-tracking.png")),
            ("The car around the damper against the car around the damper model",
             save(_responses(ch, units), out / "hil-responses.png"))]
    from protocols.library import roads  # here: the protocols bring scipy.signal, a second to import
    for _name, m in found:
        spec = m.get("road", "")
        if spec.startswith("sweep:"):
            figs.append((f"Transmissibility over the sweep ({spec})",
                         save(_transmissibility(ch, roads.parse(spec, 1000.0).band_hz), out / "hil-transmissibility.png")))
    return figs


def _tracking(ch, units):
    X = lambda si: units.show("length", si)
    x_label = units.label("damper x", "length")
    t, target = ch["hil.x_target"]
    measured = np.interp(t, *ch["x"])
    error = ch["hil.error"][1]
    fig, ax = plt.subplots(3, 1, figsize=(11, 8))
    ax[0].plot(t, X(target), label="target (the car)")
    ax[0].plot(t, X(measured), ":", label="measured (LVDT)")
    ax[0].set(ylabel=x_label, title="The whole road")
    i = int(np.argmax(np.abs(error)))  # half a second around the largest error
    k = (t >= t[i] - 0.25) & (t <= t[i] + 0.25)
    ax[1].plot(t[k], X(target[k]), label="target")
    ax[1].plot(t[k], X(measured[k]), ":", label="measured")
    ax[1].plot(t[k], X(np.interp(t[k], *ch["hil.x_command"])), "--", lw=0.8, label="command sent")
    ax[1].set(ylabel=x_label, title="Around the largest tracking error")
    ax[2].plot(t, X(error), lw=0.6)
    ax[2].set(xlabel="time [s]", ylabel=units.label("measured - target", "length"))
    for a in ax:
        a.grid(alpha=0.3)
    ax[0].legend(fontsize=8)
    ax[1].legend(fontsize=8)
    return fig


def _responses(ch, units):
    """The three responses, whole run and one second about the largest body-acceleration
    difference; travel from static equilibrium (the reference's start, the car at rest)."""
    fig, ax = plt.subplots(3, 2, figsize=(11, 8), gridspec_kw={"width_ratios": [3, 1]})
    t_ref, acc_ref = ch["hil.ref.body_acc"]
    t, acc = ch["hil.body_acc"]
    i = int(np.argmax(np.abs(acc - np.interp(t, t_ref, acc_ref))))
    window = (t[i] - 0.5, t[i] + 0.5)
    static = ch["hil.ref.travel"][1][0]
    for row, (hil, ref, name_, quantity, at) in enumerate((
            ("hil.body_acc", "hil.ref.body_acc", "body acceleration", "acceleration", 0.0),
            ("hil.x_target", "hil.ref.travel", "travel from static", "length", static),
            ("hil.tire_load", "hil.ref.tire_load", "tire load", "force", 0.0))):
        for col, a in enumerate(ax[row]):
            for name, lw, alpha, label_ in ((ref, 1.5, 0.7, "reference (damper model)"),
                                            (hil, 0.7, 1.0, "hardware in the loop")):
                tt, v = ch[name]
                k = slice(None) if col == 0 else (tt >= window[0]) & (tt <= window[1])
                a.plot(tt[k], units.show(quantity, v[k] - at), lw=lw, alpha=alpha, label=label_)
            a.grid(alpha=0.3)
        ax[row][0].set(ylabel=units.label(name_, quantity))
    ax[0][0].set_title("The whole road")
    ax[0][1].set_title("Largest difference (1 s)")
    ax[0][0].legend(fontsize=8)
    for a in ax[2]:
        a.set(xlabel="time [s]")
    return fig


def _transmissibility(ch, band):
    """Body over road: the acceleration ratio (the displacements' ratio, both differentiated
    twice), of the run and of the reference."""
    t, road = ch["hil.road"]
    h = t[1] - t[0]
    road_acc = np.gradient(np.gradient(road, h), h)
    fig, ax = plt.subplots(figsize=(8, 5))
    for name, label in (("hil.ref.body_acc", "reference (damper model)"), ("hil.body_acc", "hardware in the loop")):
        body = np.interp(t, *ch[name])
        f, mag = transmissibility(t, road_acc, body, *band)
        ax.loglog(f, mag, label=label)
    ax.set(xlabel="frequency [Hz]", ylabel="|body / road|", title="Sprung-mass transmissibility")
    ax.grid(alpha=0.3, which="both")
    ax.legend(fontsize=8)
    return fig


def _replay(ch, events, out, units):
    """The NRMS error by iteration, and the last iteration's target, measured motion and
    drive."""
    errors = replay_errors(events)
    last = [e for e in events if isinstance(e, SegmentStart) and segment_kind(e.params) == "road"]
    if not errors or not last:
        return []
    fig, ax = plt.subplots(2, 1, figsize=(11, 7), gridspec_kw={"height_ratios": [1, 2]})
    ax[0].semilogy([i for i, _ in errors], [100 * v for _, v in errors], "o-")
    ax[0].set(xlabel="iteration", ylabel="NRMS error [%]", title="Drive correction by iteration",
              xticks=[i for i, _ in errors])
    t0 = last[-1].t
    for name, label, style in (("replay.target", "target", "-"), ("replay.drive", "drive sent", "--")):
        t, v = ch[name]
        k = t >= t0
        ax[1].plot(t[k], units.show("length", v[k]), style, lw=0.8, label=label)
    t, e = ch["replay.error"]
    k = t >= t0
    ax[1].plot(t[k], units.show("length", ch["replay.target"][1][k] + e[k]), ":", lw=0.8, label="measured")
    ax[1].set(xlabel="time [s]", ylabel=units.label("damper x", "length"), title=f"The last iteration ({last[-1].segment})")
    for a in ax:
        a.grid(alpha=0.3, which="both")
    ax[1].legend(fontsize=8)
    return [("Replay: the drive corrected until the damper follows the target", save(fig, out / "replay.png"))]
