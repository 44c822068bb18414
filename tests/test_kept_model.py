"""The measurement model's executables kept across processes (gyrojax.physics.kept_model): a built-in model's
predict and Jacobian (one pass) through the kept executable of its kind's library equal the jitted functions of the
model to rounding, a reload does not compile, other models of one library share the executable, a file of another
function under the key's name is compiled again (never called), a model with an effect the user registered is never
kept, and a function closing over a model and constants is kept under a name of both."""

import jax
import jax.numpy as jnp
import numpy as np
import pytest

from gyrojax.data import plans
from gyrojax.inference.campaign import Campaign
from gyrojax.physics import expression as ex
from gyrojax.physics import kept_model
from gyrojax.physics.model import Model, jacobian_jit, measurements, predict_jit
from gyrojax.report.demo import TRUTH
from gyrojax.runtime import kept, rows
from gyrojax.simulation.simulator import simulate


@pytest.fixture(scope="module")
def data():
    recs = simulate(plans.tumble(revolutions=1.0, dt_s=60.0), TRUTH, seed=1)
    return Campaign.of(recs[:1]).data[0]


@pytest.fixture
def where(tmp_path, monkeypatch):
    monkeypatch.setattr(kept, "folder", lambda: tmp_path / "k")
    kept_model._kept_library.cache_clear()
    yield tmp_path / "k"
    kept_model._kept_library.cache_clear()


MODEL = Model(("D_F", "D_I", "D_S", "D_SS"))


def _file(stem: str, model: Model = MODEL) -> str:
    return kept_model.model_name(stem, kept_model.library(model)) + "-*.xla"


def _close(a, b):
    """Equal to rounding: the library sums the model's terms in its own order."""
    b = np.asarray(b)
    np.testing.assert_allclose(np.asarray(a), b, rtol=0, atol=1e-13 * (float(np.max(np.abs(b))) + 1.0))


def test_kept_model_functions_equal_the_jitted_ones_and_reload_without_tracing(data, where, monkeypatch):
    theta = jnp.linspace(0.1, 0.4, MODEL.size)
    y, j = kept_model.kept_predict_and_jacobian(MODEL, theta, data)
    assert len(list(where.glob(_file("predict_jacobian")))) == 1
    _close(j, jacobian_jit(MODEL, theta, data))
    _close(y, predict_jit(MODEL, theta, data))
    _close(kept_model.kept_predict(MODEL, theta, data), y)
    kept_model._kept_library.cache_clear()  # as in a fresh process

    def no_compile(*a, **k):
        raise AssertionError("compiled again")

    monkeypatch.setattr(kept, "_compile", no_compile)
    np.testing.assert_array_equal(np.asarray(kept_model.kept_predict_and_jacobian(MODEL, 2 * theta, data)[1]), j)


def test_a_foreign_file_under_the_key_is_compiled_again(data, where):
    theta = jnp.zeros(MODEL.size)
    kept_model.kept_predict_and_jacobian(MODEL, theta, data)
    (path,) = where.glob(_file("predict_jacobian"))
    other = jax.jit(lambda x: 2.0 * x).lower(jax.ShapeDtypeStruct((3,), np.float64)).compile()
    path.write_bytes(kept._written(other, "0" * 64))  # a valid executable of another function and shape
    kept_model._kept_library.cache_clear()
    with pytest.warns(UserWarning, match="another key"):
        _, j = kept_model.kept_predict_and_jacobian(MODEL, theta, data)
    _close(j, jacobian_jit(MODEL, theta, data))


def test_a_model_with_a_user_effect_is_not_kept(data, where):
    with ex.defined("U_kept=a_I**3") as (name,):
        model = Model(("D_F", name))
        assert not kept_model.keepable(model) and kept_model.keepable(MODEL)
        _, j = kept_model.kept_predict_and_jacobian(model, jnp.zeros(2), data)
        np.testing.assert_array_equal(np.asarray(j), np.asarray(jacobian_jit(model, jnp.zeros(2), data)))
    assert not where.exists()


def test_kept_jit_names_its_model_and_constants_and_keeps_no_user_effect(where):
    """A function closing over a model and constants (the campaign loop's design search) is kept under a name of both:
    other constants, another file; it computes what ``jax.jit`` computes, and a user effect's is jitted, never kept."""
    a = kept_model.kept_jit("f", MODEL, lambda x: 2.0 * x, 8, (0.0, 90.0))
    b = kept_model.kept_jit("f", MODEL, lambda x: 2.0 * x, 8, (0.0, 91.0))
    assert isinstance(a, kept.Kept) and a.name.startswith(kept_model.model_name("f", MODEL)) and a.name != b.name
    np.testing.assert_array_equal(np.asarray(a(np.arange(3.0))), [0.0, 2.0, 4.0])
    assert len(list(where.glob(a.name + "-*.xla"))) == 1
    with ex.defined("U_jit=a_I**3") as (name,):
        c = kept_model.kept_jit("f", Model(("D_F", name)), lambda x: 2.0 * x, 8)
        assert not isinstance(c, kept.Kept)


def _plan_data(plan):
    from gyrojax.data.arrays import record_data
    from gyrojax.simulation.simulator import plan_records

    return record_data(plan_records(plan)[0])


@pytest.mark.parametrize(
    "plan, kind, mode",
    [
        (lambda: plans.tumble(revolutions=1.0, dt_s=60.0), "sdf-gyro", "rebalance"),
        (lambda: plans.servo(hours=0.1, dt_s=1.0), "sdf-gyro", "servo"),  # the pieces share their end samples
        (lambda: plans.tdf_tumble(), "tdf-gyro", "rebalance"),  # channel X's rows, then channel Y's
        (lambda: plans.accel_tumble(positions=8, dwell_s=20.0), "pendulous-accel", "rebalance"),
    ],
)
def test_a_record_in_pieces_predicts_as_the_whole_record(plan, kind, mode, where, monkeypatch):
    """Every mode and kind through pieces of a few rows (many pieces, the last one padded): the prediction and the
    Jacobian of the whole record, jitted on it at once, to rounding (the compiled pieces may vectorise the sums of
    the model's terms in another order)."""
    from gyrojax.physics import effects as fx

    monkeypatch.setattr(rows, "CHUNK_ROWS", 37)
    data = _plan_data(plan())
    model = Model(tuple(t for t in fx.names(kind) if t not in fx.TEMPERATURE_EFFECTS), kind)
    theta = np.random.default_rng(0).normal(0.0, 0.3, model.size)
    y, j = kept_model.kept_predict_and_jacobian(model, theta, data)
    assert data.mode == mode and data.kind == kind and measurements(data) > 3 * rows.CHUNK_ROWS
    y0, j0 = predict_jit(model, theta, data), jacobian_jit(model, theta, data)
    assert y.shape == y0.shape and j.shape == j0.shape
    scale = float(np.max(np.abs(np.asarray(y0)))) + 1.0
    np.testing.assert_allclose(y, np.asarray(y0), rtol=0, atol=1e-13 * scale)
    np.testing.assert_allclose(j, np.asarray(j0), rtol=0, atol=1e-13 * (float(np.max(np.abs(np.asarray(j0)))) + 1.0))
    assert len(list(where.glob(_file("predict_jacobian", model)))) == 1


def test_records_of_any_length_share_one_executable(where, monkeypatch):
    """Two records of other lengths, each at least a chunk, call one executable per model (the chunk size's), none
    compiled for the second."""
    short, long = (_plan_data(plans.tumble(revolutions=1.0, dt_s=s)) for s in (60.0, 20.0))
    assert short.time_s.shape != long.time_s.shape
    monkeypatch.setattr(rows, "CHUNK_ROWS", min(measurements(short), measurements(long)) // 2)
    kept_model.kept_predict_and_jacobian(MODEL, np.zeros(MODEL.size), short)

    def no_compile(*a, **k):
        raise AssertionError("compiled again")

    monkeypatch.setattr(kept, "_compile", no_compile)
    _, j = kept_model.kept_predict_and_jacobian(MODEL, np.zeros(MODEL.size), long)
    np.testing.assert_allclose(j, np.asarray(jacobian_jit(MODEL, np.zeros(MODEL.size), long)), rtol=0, atol=1e-12)
    assert len(list(where.glob(_file("predict_jacobian")))) == 1


def test_models_of_one_library_share_its_executable(data, where, monkeypatch):
    """Another model of the library (other terms, a θ of the same padded length) loads the executable the first one
    compiled: a diagnosis that adds an effect compiles nothing; a set-up effect takes the library with the kinematics'
    derivatives, an effect not linear in the rate the one with the servo's Newton steps."""
    kept_model.kept_predict_and_jacobian(MODEL, np.zeros(MODEL.size), data)

    def no_compile(*a, **k):
        raise AssertionError("compiled again")

    monkeypatch.setattr(kept, "_compile", no_compile)
    other = Model(("D_IS", "sf_error", "D_O", "D_F"))
    theta = np.linspace(-1.0, 2.0, other.size)
    y, j = kept_model.kept_predict_and_jacobian(other, theta, data)
    assert j.shape == (y.size, other.size)
    _close(j, jacobian_jit(other, theta, data))
    _close(y, predict_jit(other, theta, data))
    assert kept_model.library(other) == kept_model.library(MODEL)
    assert not {e.setup for e in kept_model.library(MODEL).effects} - {False}
    assert "table_tilt" in kept_model.library(MODEL.extend("table_tilt")).terms
    assert "sf_asymmetry" not in kept_model.library(MODEL).terms
    assert "sf_asymmetry" in kept_model.library(MODEL.extend("sf_asymmetry")).terms
    assert [kept_model.padded(p) for p in (0, 1, 4, 5, 9, 17)] == [4, 4, 4, 8, 16, 32]
