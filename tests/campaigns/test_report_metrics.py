"""Report metrics: a campaign metric read from a run's summary ``reports`` by a dotted path.

The path walk is checked on a hand-made reports dict (nested keys, list indices, None -> NaN, numpy
values as the in-memory summary holds them, each way a path can fail); the whole chain on one short
run of snow-screw-traverse (two base steps), whose soil contact reports per-screw sinkage, the rut and a
driven slip that is None (the screws are idle while the robot settles): the metrics must equal the numbers
in that run's summary.json, read back independently.
"""

from __future__ import annotations

import json
import math
import textwrap

import numpy as np
import pytest

from snakesim.campaigns.campaign import prepare
from snakesim.campaigns.metrics import Metric, MetricError, ReportMetric, evaluate, parse_metrics, report_value
from snakesim.campaigns.runner import SceneSpec, execute
from snakesim.framework.errors import ConfigError

REPORTS = {"carriage": {"slip": 0.125, "travel_speed_m_s": None, "settled": True, "link": "module_03",
                        "window_s": [1.5, 2.0]},
           "contact": {"mean_sinkage_m": [0.01, np.float32(0.02), None], "rut": {"rut_volume_m3": np.float64(3e-3),
                                                                                "bounds": np.array([1.0, 2.0])}},
           "broken": {"error": "ZeroDivisionError: division by zero"}}


def test_a_report_path_walks_keys_and_list_indices_and_none_is_nan():
    assert report_value(REPORTS, "carriage.slip") == 0.125
    assert report_value(REPORTS, "carriage.settled") == 1.0                   # a bool counts 0/1
    assert report_value(REPORTS, "contact.mean_sinkage_m.0") == 0.01
    assert report_value(REPORTS, "contact.mean_sinkage_m.1") == float(np.float32(0.02))
    assert report_value(REPORTS, "contact.rut.rut_volume_m3") == 3e-3
    assert report_value(REPORTS, "contact.rut.bounds.1") == 2.0              # an array is a list, as in the JSON
    assert math.isnan(report_value(REPORTS, "carriage.travel_speed_m_s"))
    assert math.isnan(report_value(REPORTS, "contact.mean_sinkage_m.2"))


@pytest.mark.parametrize("path, message", [
    ("carriage.slipp", "reports.carriage has no 'slipp'; keys there: slip, travel_speed_m_s, settled, link"),
    ("nosuch.slip", "reports has no 'nosuch'; keys there: carriage, contact, broken"),
    ("contact.rut", "reports.contact.rut is a mapping, not a number; keys there: rut_volume_m3, bounds"),
    ("contact.mean_sinkage_m", "reports.contact.mean_sinkage_m is a list of 3, not a number; add one of its "
                               "indices 0..2"),
    ("contact.mean_sinkage_m.3", "'3' is not one of its indices 0..2"),
    ("contact.mean_sinkage_m.first", "'first' is not one of its indices 0..2"),
    ("carriage.link", "reports.carriage.link is a str ('module_03'), not a number"),
    ("carriage.slip.x", "reports.carriage.slip is a float (0.125), it has no 'x'"),
    ("broken.slip", "has no 'slip' (its report failed: ZeroDivisionError: division by zero)"),
])
def test_a_report_path_that_does_not_lead_to_a_number_names_the_path_and_what_is_there(path, message):
    with pytest.raises(MetricError) as e:
        report_value(REPORTS, path)
    assert str(e.value).startswith(f"report '{path}': ") and message in str(e.value)


def test_a_run_without_reports_is_an_error_for_a_report_metric():
    with pytest.raises(MetricError, match="the run's summary has no reports"):
        report_value(None, "carriage.slip")


@pytest.mark.parametrize("spec, message, key", [
    ({"signal": "pend.theta", "report": "carriage.slip"}, "both 'signal' and 'report'", "metrics.m"),
    ({"report": "carriage.slip", "reduce": "final"}, "'reduce' does not go with 'report'", "metrics.m.reduce"),
    ({"report": "carriage.slip", "index": 0}, "unknown key 'index'", "metrics.m"),
    ({"reduce": "max"}, "neither 'signal' nor 'report'", "metrics.m"),
    ({"report": "carriage"}, "must be a dotted path COMPONENT.KEY", "metrics.m.report"),
    ({"report": "carriage..slip"}, "must be a dotted path COMPONENT.KEY", "metrics.m.report"),
    ({"report": 3}, "must be a dotted path COMPONENT.KEY", "metrics.m.report"),
])
def test_a_bad_metric_spec_is_a_config_error_naming_file_key_and_both_kinds(spec, message, key):
    with pytest.raises(ConfigError) as e:
        parse_metrics({"m": spec}, "d.yaml")
    assert e.value.key == key and e.value.where == "d.yaml" and message in e.value.detail
    assert "{signal: COMPONENT.PORT, reduce: R} or {report: COMPONENT.KEY" in e.value.detail or key.endswith("report")


def test_both_kinds_parse_side_by_side():
    got = parse_metrics({"a": {"signal": "pend.theta", "reduce": "max"}, "b": {"report": "contact.rut.x"}}, "d.yaml")
    assert got == (Metric("a", "pend.theta", "max"), ReportMetric("b", "contact.rut.x"))
    assert got[1].component == "contact"


SCENE = SceneSpec("snow-screw-traverse", sim=(("duration", 0.04),))       # two 20 ms base steps
DISPERSIONS = """
dispersions:
  screw_speed: {dist: grid, values: [3.0]}
metrics:
"""


def _plan(tmp_path, metrics: str):
    f = tmp_path / "snow-dispersions.yaml"
    f.write_text(textwrap.dedent(DISPERSIONS).lstrip("\n") + textwrap.indent(textwrap.dedent(metrics), "  "))
    return prepare(SCENE, str(f), 1)


def test_a_report_metric_naming_no_reporting_component_is_refused_before_any_run(tmp_path):
    with pytest.raises(ConfigError) as e:
        _plan(tmp_path, "slip: {report: nosuch.slip}\n")
    assert e.value.key == "metrics.slip.report" and "'nosuch' is not a component of the scene" in e.value.detail
    assert "robot" in e.value.detail and "those that report: contact" in e.value.detail
    with pytest.raises(ConfigError, match="component 'terrain' .* gives no report; .* that report: contact"):
        _plan(tmp_path, "t: {report: terrain.x}\n")


def test_report_metrics_of_a_run_equal_its_summary_json_and_a_bad_path_is_that_runs_error(tmp_path):
    plan = _plan(tmp_path, """
        sink0: {report: contact.mean_sinkage_m.0}
        sink_last: {report: contact.mean_sinkage_m.19}
        rut: {report: contact.rut.rut_volume_m3}
        slip3: {report: contact.mean_slip_driven.3}
        x_final: {signal: tail_pose.pose.x, reduce: final}
    """)
    rec = execute(plan.task(0, tmp_path / "out", True, None))
    assert rec["status"] == "ok", rec["reason"]
    summary = json.loads((tmp_path / "out" / "runs" / "run-00000" / "summary.json").read_text())
    contact = summary["reports"]["contact"]
    assert contact["mean_slip_driven"][3] is None and contact["rut"]["rut_volume_m3"] > 0
    m = rec["metrics"]
    assert m["sink0"] == contact["mean_sinkage_m"][0] and m["sink_last"] == contact["mean_sinkage_m"][19]
    assert m["rut"] == contact["rut"]["rut_volume_m3"] and math.isnan(m["slip3"])
    assert set(m) == {"sink0", "sink_last", "rut", "slip3", "x_final"}

    # the same scene again (the session is reused): a path this run's report lacks, one on a mapping
    for metric, message in (("rut: {report: contact.rut.nosuch}",
                             "metrics: MetricError: report 'contact.rut.nosuch': reports.contact.rut has no 'nosuch'; "
                             f"keys there: {', '.join(contact['rut'])}"),
                            ("rut: {report: contact.rut}", "reports.contact.rut is a mapping, not a number")):
        rec = execute(_plan(tmp_path, metric + "\n").task(0, None, False, None))
        assert rec["status"] == "error" and rec["metrics"] == {} and rec["reason"].startswith("metrics: ")
        assert message in rec["reason"]


def test_evaluate_without_a_summary_keeps_signal_metrics_working():
    class Log:                        # the recorder's surface evaluate reads
        columns = ["t", "pend.theta"]
        refs, slices = [], []
        rows = np.array([[0.0, 1.0], [0.1, 3.0]])

    assert evaluate((Metric("th", "pend.theta", "max"),), Log()) == {"th": 3.0}
    with pytest.raises(MetricError, match="no reports"):
        evaluate((ReportMetric("s", "carriage.slip"),), Log())
