"""The focus+context magnified axis of the transfer-function editor (HDR VolVis Eq. 2;
../shared/notes/methods.md C.1.2): exact against numerical integration, the worked
example, the closed-form inverse, and clear errors."""
import numpy as np
import pytest
from scipy.integrate import quad

from pv_hdrvol.editor.axis import Focus, FocusContextAxis

pytestmark = pytest.mark.core

CASES = {
    "one focus": [Focus(0.5, 0.1, 4.0, transition=0.05)],
    "clipped at 0": [Focus(0.05, 0.1, 3.0, transition=0.2)],
    "clipped at both ends": [Focus(0.5, 0.6, 1.05, transition=0.5)],
    "two foci": [Focus(0.2, 0.1, 2.5), Focus(0.7, 0.04, 3.0, transition=0.05)],
    "step transitions": [Focus(0.3, 0.2, 2.0, transition=0.0), Focus(0.8, 0.1, 3.0, transition=0.0)],
}


def test_the_worked_example():
    """Focus 0.1 wide magnified 4x, transitions 0.05: M_min = 0.4 / 0.85 = 0.470588,
    and 0.470588 * 0.8 + 4 * 0.1 + (0.470588 + 4) / 2 * 0.1 = 1 (the paper's shortcut)."""
    axis = FocusContextAxis([Focus(0.5, 0.1, 4.0, transition=0.05)])
    assert axis.m_min == pytest.approx(0.4 / 0.85, rel=1e-15)
    assert round(axis.m_min, 4) == 0.4706
    assert axis.m_min * 0.8 + 4 * 0.1 + (axis.m_min + 4) / 2 * 0.1 == pytest.approx(1.0, rel=1e-15)
    np.testing.assert_allclose(axis.magnification([0.2, 0.5, 0.425, 0.575]),  # transitions' middles
                               [axis.m_min, 4.0, (axis.m_min + 4) / 2, (axis.m_min + 4) / 2], rtol=1e-13)


@pytest.mark.filterwarnings("ignore::scipy.integrate.IntegrationWarning")  # quad's own estimate, not ours
@pytest.mark.parametrize("name", sorted(CASES))
def test_screen_mapping_is_the_integral_of_the_magnification(name):
    axis = FocusContextAxis(CASES[name])
    knots = sorted({min(max(k, 0.0), 1.0) for f in axis.foci for k in f.knots})
    x = np.linspace(0.0, 1.0, 41)
    expected = [quad(axis.magnification, 0.0, v, points=[k for k in knots if 0 < k < v] or None, epsabs=1e-14,
                     epsrel=1e-14, limit=200)[0] if v > 0 else 0.0 for v in x]
    np.testing.assert_allclose(axis.forward(x), expected, rtol=0, atol=1e-12)
    assert axis.forward(1.0) == pytest.approx(1.0, abs=1e-14) and axis.forward(0.0) == 0.0
    assert 0 < axis.m_min < 1 and np.all(np.diff(axis.forward(np.linspace(0, 1, 10001))) > 0)


@pytest.mark.parametrize("name", sorted(CASES))
def test_inverse_is_closed_form_and_exact(name):
    axis = FocusContextAxis(CASES[name])
    x = np.linspace(0.0, 1.0, 10001)
    np.testing.assert_allclose(axis.inverse(axis.forward(x)), x, rtol=0, atol=1e-12)
    s = np.random.default_rng(3).random(1000)
    np.testing.assert_allclose(axis.forward(axis.inverse(s)), s, rtol=0, atol=1e-12)


def test_no_focus_is_the_identity():
    axis = FocusContextAxis()
    x = np.linspace(0, 1, 7)
    assert axis.m_min == 1.0
    np.testing.assert_array_equal(axis.forward(x), x)
    np.testing.assert_array_equal(axis.inverse(x), x)


@pytest.mark.parametrize("make, error, match", [
    (lambda: FocusContextAxis([Focus(0.3, 0.2), Focus(0.5, 0.2)]), ValueError, "foci must not overlap"),
    (lambda: FocusContextAxis([Focus(0.5, 0.4, 3.0)]), ValueError,
     r"the foci magnify more than the axis holds: sum of magnification x weighted width = 1.8 must be < 1"),
    (lambda: Focus(0.5, 0.1, 1.0), ValueError, "magnification must be > 1.0; got 1.0"),
    (lambda: Focus(0.02, 0.1), ValueError, r"the focus \[-0.03, 0.07\] must lie within the axis \[0, 1\]"),
    (lambda: Focus(0.5, 0.0), ValueError, "width must be > 0.0; got 0.0"),
    (lambda: Focus(0.5, 0.1, transition=-0.1), ValueError, "transition must be >= 0.0; got -0.1"),
    (lambda: FocusContextAxis([(0.5, 0.1)]), TypeError, "foci\\[0\\] must be a Focus; got tuple"),
])
def test_bad_foci_are_refused(make, error, match):
    with pytest.raises(error, match=match):
        make()


def test_log_value_axis_shows_six_decades_and_snaps_to_zero():
    from pv_hdrvol.editor.axis import ValueAxis

    axis = ValueAxis("log", floor=1e-6, top=1.0, snap=0.02)
    y = np.logspace(-5.8, 0, 200)
    np.testing.assert_allclose(axis.inverse(axis.forward(y)), y, rtol=1e-12)
    np.testing.assert_allclose(axis.forward([1e-6, 1e-4, 1e-2, 1.0]), [0, 1 / 3, 2 / 3, 1], atol=1e-15)
    assert axis.forward(0.0) == 0.0 and axis.forward(1e-9) == 0.0 and axis.forward(5.0) == 1.0
    assert axis.inverse(0.02) == 0.0 and axis.inverse(0.0) == 0.0 and axis.inverse(0.021) > 1e-6
    colour = ValueAxis("log", floor=1e-3, top=1e4)  # an HDR colour axis: seven decades
    assert colour.inverse(1.0) == pytest.approx(1e4, rel=1e-12) and colour.forward(1.0) == pytest.approx(3 / 7)
    linear = ValueAxis("linear", top=2.0)
    np.testing.assert_array_equal(linear.forward([0.0, 1.0, 2.0, 3.0]), [0.0, 0.5, 1.0, 1.0])
    np.testing.assert_array_equal(linear.inverse([0.0, 0.5]), [0.0, 1.0])
    with pytest.raises(ValueError, match="floor must be < 1.0; got 1.0"):
        ValueAxis(floor=1.0, top=1.0)
    with pytest.raises(ValueError, match=r"scale must be one of \['log', 'linear'\]; got 'symlog'"):
        ValueAxis("symlog")
