"""The report's peak-force table and comparison on rows made by hand."""
import numpy as np

from protocols.reports import peaks
from protocols.reports.recording import force_temperature_figure


def _peak(amp, freq, T, F, target=np.nan):
    return peaks.Peak(f"sine {amp} mm {freq} Hz", amp, freq, target, T, 0.1 * freq, F, -0.1 * freq, -1.5 * F)


def test_the_comparison_pairs_segments_and_gives_b_against_a():
    a = [_peak(12.7, 4, 20, 1000.0), _peak(12.7, 8, 20, 2000.0), _peak(3.2, 4, 20, 500.0)]
    b = [_peak(12.7, 8, 21, 2200.0), _peak(12.7, 4, 21, 900.0), _peak(6.4, 4, 21, 700.0)]
    head, rows = peaks.compare(a, b)
    assert [r[:2] for r in rows] == [("12.7", "4"), ("12.7", "8")]  # 3.2 and 6.4 mm: only in one
    assert rows[0][head.index("diff comp [%]")] == "-10.0" and rows[1][head.index("diff reb [%]")] == "+10.0"


def test_peak_force_against_temperature_only_where_temperatures_differ(tmp_path):
    same = [_peak(12.7, 2, 20, 1000.0), _peak(12.7, 2, 22, 990.0)]
    assert force_temperature_figure(same, tmp_path) == []
    swept = [_peak(12.7, 2, T, 1500.0 - 5 * T, target=T) for T in (30, 45, 60)]
    assert force_temperature_figure(swept + same, tmp_path) == [("Peak force against temperature",
                                                                 "force_temperature.png")]
    assert (tmp_path / "force_temperature.png").stat().st_size > 10_000


def test_the_csv_has_a_column_per_field(tmp_path):
    path = peaks.write_csv([_peak(12.7, 4, 20, 1000.0)], tmp_path / "p.csv")
    head, row = path.read_text().splitlines()
    assert head.split(",") == list(peaks.HEADER) and row.startswith("sine 12.7 mm 4 Hz,12.7,4,nan,20,")
