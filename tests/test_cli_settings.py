"""--set NAME=VALUE and PLUGIN.NAME=VALUE: which settings reach which integrator."""
from lift_gl.cli import _settings


def test_plugin_prefixed_settings_reach_their_plugin_by_name_or_folder():
    pairs = ["max_depth=3", "pt.rr_depth=2", "pt_lab.mis=false", "bdpt.max_depth=9"]
    assert _settings(pairs, "pt") == {"max_depth": "3", "rr_depth": "2"}
    assert _settings(pairs, "labs/lab2-path-tracing/solution/pt_lab") == {"max_depth": "3", "mis": "false"}
    assert _settings(pairs, "bdpt") == {"max_depth": "9"}
