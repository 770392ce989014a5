"""`dyno bench`'s arguments, beside its commands."""
from __future__ import annotations

from commands.arguments import cluster_option, number


def _bench(bsub, name, help):
    """A benchmark's parser: its numbers as text, --json or stamped --markdown."""
    b = bsub.add_parser(name, help=help)
    b.add_argument("--json", action="store_true")
    b.add_argument("--markdown", action="store_true", help="stamped Markdown for docs/results")
    b.set_defaults(command=f"bench:{name}")
    return b


def add(sub):
    """Benchmarks (measured numbers, not tests)."""
    b = sub.add_parser("bench", help="benchmarks (not tests)")
    bsub = b.add_subparsers(dest="what", required=True)
    bs = _bench(bsub, "sim", help="compressible model speed vs a solve_ivp Radau reference")
    bs.add_argument("--seconds", type=number(above=0, hi=3600), default=10.0, help="simulated seconds (default 10)")
    bs.add_argument("--ref-seconds", type=number(above=0, hi=3600), default=None,
                    help="simulate only this much with the slow reference (default: all)")
    bw = _bench(bsub, "sweep", help="quarter-car frequency sweep time (2 amplitudes x 60 frequencies, Koni)")
    bw.add_argument("--workers", type=number(1, 256, integer=True), default=None,
                    help="processes (default: all cores)")
    cluster_option(bw)
    bim = _bench(bsub, "import", help="dyno import's time on 1,000,000 CSV rows (goal < 5 s)")
    bim.add_argument("--rows", type=number(10, 10**8, integer=True), default=1_000_000)
    bim.set_defaults(command="bench:import_")
    bg = _bench(bsub, "log", help="samples per second into MCAP against a protocol's data rate")
    bg.add_argument("--seconds", type=number(above=0, hi=3600), default=5.0)
    bi = _bench(bsub, "identify", help="dyno identify's time on a full standard sequence (goal < 2 min)")
    bi.add_argument("recording", nargs="?", default=None,
                    help="a standard-sequence recording (default: record one on the virtual rig first, ~4 min)")
    bi.add_argument("--damper", default="koni",
                    help="damper(s) for the recording made first, comma-separated (default koni)")
    bi.add_argument("--truth", action="store_true", help="compare with the damper the rig ran (the round trip)")
    bd = _bench(bsub, "diagnose", help="dyno diagnose's time on 60 s of sine matrix at 5 kHz (goal < 2 s), or "
                                       "--crank: 100 s of a slider-crank at 300 Hz with five effects (goal < 5 s); each by stage")
    bd.add_argument("--crank", action="store_true", help="a crank dyno's recording (proof/bench/crank.py)")
    bd.add_argument("--seconds", type=number(above=0, hi=3600), default=None, help="recorded (default 60, crank 100)")
    bd.add_argument("--rate", type=number(above=0, hi=100000), default=None,
                    help="sample rate [Hz] (default 5000, crank 300)")
    bd.add_argument("--runs", type=number(1, 50, integer=True), default=3,
                    help="diagnoses of the one recording: minimum, median and maximum (default 3)")
    bdc = _bench(bsub, "discover", help="dyno run discover's wall time against its budget (goal <= 1.2 x)")
    bdc.add_argument("--budget", type=number(above=0, hi=3600), default=60.0,
                     help="rig time its own tests may add [s] (default 60)")
    bh = _bench(bsub, "hil", help="hardware-in-the-loop tracking of each compensator on three roads")
    bh.add_argument("--damper", default="koni", help="damper preset or FILE.json (default koni)")
    bc = _bench(bsub, "cluster", help="prove and a sweep on one worker and on a Dask LocalCluster")
    bc.add_argument("--workers", type=number(1, 64, integer=True), default=2, help="cluster workers (default 2)")
    bc.add_argument("--prove-tasks", type=number(1, 1000, integer=True), default=6,
                    help="prove runs (default 6, about a minute each)")
    bc.add_argument("--sweep-tasks", type=number(1, 10000, integer=True), default=60,
                    help="harmonic points (default 60)")
    bk = _bench(bsub, "catalogue", help="the run index and its browser view at 1,000 runs; dyno check's time")
    bk.add_argument("--runs", type=number(1, 100000, integer=True), default=1000, help="recordings (default 1000)")
    bk.add_argument("--check-recording", default=None,
                    help="a standard recording to time dyno check on (default: record one on the direct cell first)")
    bl = _bench(bsub, "loop", help="control loop timing in real time against sim-rig in a separate process")
    bl.add_argument("--rate", type=number(above=0, hi=5000), default=1000.0, help="loop rate in Hz (default 1000)")
    bl.add_argument("--seconds", type=number(above=0, hi=3600), default=30.0, help="duration (default 30)")
    bl.add_argument("--embedded", action="store_true",
                    help="the embedded virtual rig in real time (dyno run --realtime) instead of sim-rig")
    bl.add_argument("--busy", type=number(0, 64, integer=True), default=0,
                    help="programs keeping a core busy each beside the loop (default 0)")
    bl.add_argument("--diagnose", action="store_true",
                    help="with the live diagnosis's worker diagnosing sine segments all along, beside the controller")
