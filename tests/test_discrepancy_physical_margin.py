"""The tie margin of an effect held at its physical value between two fits on the same non-linear
footing: the data's margin on that footing, not the wide one of the footing's germ luck."""

from types import SimpleNamespace

import pytest

from uqdrive.inference.discrepancy import selection
from uqdrive.vehicle.effects import PHYSICAL


class _Finder:
    """Stand-in: chi2 as given, the footing of a fit its attribute, the wide margin 2 x footing x 500
    for any non-linear fit (the footing band's chi2 sd 500), else the margin given."""

    def _chi2(self, fit):
        return fit.chi2

    def _footing(self, fit):
        return fit.footing

    def _margin(self, margin, *fits):
        return max([margin] + [2.0 * f.footing * 500.0 for f in fits if f.footing > 1.0])


def _fit(chi2, footing):
    return SimpleNamespace(chi2=chi2, footing=footing)


MARGIN, PER_PARAM = 70.0, 10.0  # 2 null sd of the data's band, 2 x its inflation


def test_a_held_physical_effect_on_the_same_germs_is_judged_by_the_datas_margin():
    """lateral_kinematics (k held at 1) saving 800 on top of a saturating tyre (footing 1.4 both):
    against 1.4 x 70 = 98 it is justified; against the wide 1400 it would not be."""
    assert "lateral_kinematics" in PHYSICAL
    f, before, after = _Finder(), _fit(1200.0, 1.4), _fit(400.0, 1.4)
    assert selection.comparison_margin(f, "lateral_kinematics", MARGIN, before, after) == pytest.approx(1.4 * MARGIN)
    assert selection._gain_justified(f, before, after, "lateral_kinematics", MARGIN, PER_PARAM)


@pytest.mark.parametrize("name, footings", [("tyre_relaxation", (1.4, 1.4)), ("lateral_kinematics", (1.0, 1.4)),
                                            ("lateral_kinematics", (1.4, 1.0))])
def test_a_fitted_parameter_or_different_germs_keep_the_wide_margin(name, footings):
    """A fitted effect (relaxation) could fit the germs' luck, and a linear against a non-linear fit
    runs on other germs: both keep the footing's wide margin, and the same saving of 800 is not
    justified."""
    f, before, after = _Finder(), _fit(1200.0, footings[0]), _fit(400.0, footings[1])
    assert selection.comparison_margin(f, name, MARGIN, before, after) == pytest.approx(1400.0)
    assert not selection._gain_justified(f, before, after, name, MARGIN, PER_PARAM)


def test_on_the_linear_footing_nothing_changes():
    """Both fits linear: the margin is the data's, the same for any effect."""
    f = _Finder()
    for name in ("lateral_kinematics", "road_bank"):
        assert selection.comparison_margin(f, name, MARGIN, _fit(900.0, 1.0), _fit(800.0, 1.0)) == MARGIN
