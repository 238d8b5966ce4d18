"""The tie margin of an effect held at its physical value between two fits on the same non-linear
footing: the data's margin on that footing, not the wide one of the footing's germ luck."""

from types import SimpleNamespace

import pytest

from uqdrive.inference.discrepancy import selection
from uqdrive.vehicle.effects import PHYSICAL


class _Comparison:
    """Stand-in: chi2 as given, the footing of a fit its attribute, the baseline band's chi2 sd 35
    (the data's noise), the wide margin 2 x footing x 500 for any non-linear fit (the footing
    band's chi2 sd 500), else the margin given."""

    band = SimpleNamespace(chi2_null_sd=35.0, inflation=1.0)

    def chi2(self, fit):
        return fit.chi2

    def footing(self, fit):
        return fit.footing

    def margin(self, margin, *fits):
        return max([margin] + [2.0 * f.footing * 500.0 for f in fits if f.footing > 1.0])


def _fit(chi2, footing):
    return SimpleNamespace(chi2=chi2, footing=footing)


MARGIN, PER_PARAM = 1000.0, 10.0  # the current band's margin (a non-linear model's: its footing band's), 2 x inflation


def test_a_held_physical_effect_on_the_same_germs_is_judged_by_the_datas_margin():
    """lateral_kinematics (k held at 1) saving 800 on top of a saturating tyre (footings 1.39 and
    1.41: the same raw germs, a few realisations more or less kept from spinning): against
    1.41 x 2 x 35 = 99 (the data's band) it is justified; against the wide 1410 or the current band's
    1000 it would not be."""
    assert "lateral_kinematics" in PHYSICAL
    f, before, after = _Comparison(), _fit(1200.0, 1.39), _fit(400.0, 1.41)
    assert selection.comparison_margin(f, "lateral_kinematics", MARGIN, before, after) == pytest.approx(1.41 * 70.0)
    assert selection._gain_justified(f, before, after, "lateral_kinematics", MARGIN, PER_PARAM)


@pytest.mark.parametrize("name, footings", [("tyre_relaxation", (1.4, 1.4)), ("lateral_kinematics", (1.0, 1.4)),
                                            ("lateral_kinematics", (1.4, 1.0))])
def test_a_fitted_parameter_or_different_germs_keep_the_wide_margin(name, footings):
    """A fitted effect (relaxation) could fit the germs' luck, and a linear against a non-linear fit
    runs on other germs: both keep the footing's wide margin, and the same saving of 800 is not
    justified."""
    f, before, after = _Comparison(), _fit(1200.0, footings[0]), _fit(400.0, footings[1])
    assert selection.comparison_margin(f, name, MARGIN, before, after) == pytest.approx(1400.0)
    assert not selection._gain_justified(f, before, after, name, MARGIN, PER_PARAM)


def test_on_the_linear_footing_nothing_changes():
    """Both fits linear, the current band the baseline's (margin 70): the same margin for any effect."""
    f = _Comparison()
    for name in ("lateral_kinematics", "road_bank"):
        assert selection.comparison_margin(f, name, 70.0, _fit(900.0, 1.0), _fit(800.0, 1.0)) == 70.0
