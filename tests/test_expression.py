"""Effects written as expressions: the AST whitelist refuses every token outside it (naming the token), values agree
with numpy, the effect is jit/vmap/grad-safe through the measurement model, and effects files load with errors that
name the file and key."""

import jax
import jax.numpy as jnp
import numpy as np
import pytest

import gyrojax as gj
from gyrojax.data.arrays import record_data
from gyrojax.physics import effects as fx
from gyrojax.physics import expression as ex
from gyrojax.physics.model import Model, predict
from gyrojax.physics.registry import unregister

RNG = np.random.default_rng(3)
X = {k: RNG.uniform(-1.0, 1.0, 50) for k in ("w_I", "w_O", "w_S", "a_I", "a_O", "a_S", "t_h", "temperature_C")}


@pytest.mark.parametrize(
    "text, ref",
    [
        ("a_I**3", lambda x: x["a_I"] ** 3),
        ("a_I*a_O - 2.5*a_S/3", lambda x: x["a_I"] * x["a_O"] - 2.5 * x["a_S"] / 3),
        ("sin(2*pi*t_h) + cos(w_I)", lambda x: np.sin(2 * np.pi * x["t_h"]) + np.cos(x["w_I"])),
        (
            "abs(w_I)*sign(a_I) + sqrt(abs(a_S)) - exp(-temperature_C)",
            lambda x: np.abs(x["w_I"]) * np.sign(x["a_I"]) + np.sqrt(np.abs(x["a_S"])) - np.exp(-x["temperature_C"]),
        ),
        ("-(a_O)**2 + +w_S", lambda x: -(x["a_O"] ** 2) + x["w_S"]),
    ],
)
def test_expressions_match_numpy(text, ref):
    f, used = ex.compile_expression(text)
    np.testing.assert_allclose(np.asarray(f({k: jnp.asarray(v) for k, v in X.items()})), ref(X), rtol=1e-13)
    assert used and all(u in X for u in used)


@pytest.mark.parametrize(
    "text, token",
    [
        ("__import__('os').system('true')", "__import__"),
        ("a_I.real", "a_I.real"),
        ("a_I[0]", "a_I[0]"),
        ("w_Z * 2", "w_Z"),
        ("foo(a_I)", "foo"),
        ("sin(a_I, 2)", "sin(a_I, 2)"),
        ("sin(x=a_I)", "sin(x=a_I)"),
        ("a_I if a_O else a_S", "a_I if a_O else a_S"),
        ("a_I @ a_O", "a_I @ a_O"),
        ("'a' + a_I", "'a'"),
        ("lambda: a_I", "lambda: a_I"),
        ("a_I < 1", "a_I < 1"),
        ("sin", "sin"),
        ("3.0", "uses no instrument input"),
        ("a_I +", "not arithmetic"),
    ],
)
def test_bad_tokens_are_named(text, token):
    with pytest.raises(ex.ExpressionError) as e:
        ex.compile_expression(text)
    assert token in str(e.value)


def test_kind_decides_the_inputs():
    ex.compile_expression("a_X*channel_is_X", fx.TDF)
    with pytest.raises(ex.ExpressionError, match="unknown input 'a_X'"):
        ex.compile_expression("a_X", fx.SDF)
    assert ex.expression_effect("T_tdfonly", "a_Z**2", fx.TDF).kinds == (fx.TDF,)
    assert fx.TDF not in ex.expression_effect("T_sdf", "a_I**2", fx.SDF).kinds


def test_names_are_checked_and_bound_for_the_process():
    with pytest.raises(ex.ExpressionError, match="NAME=EXPR"):
        ex.split_definition("a_I**3")
    with pytest.raises(ex.ExpressionError, match="already a built-in"):
        ex.define("D_I=a_I**3")
    with pytest.raises(ex.ExpressionError, match="must start with a letter"):
        ex.define("3x=a_I")
    with ex.defined("T_bound=a_I**5") as names:
        assert names == ["T_bound"] and "T_bound" in fx.names()
        assert ex.define("T_bound = a_I**5") == "T_bound"  # the same definition again is fine
    assert "T_bound" not in fx.names()
    with pytest.raises(ex.ExpressionError, match="defined as 'a_I\\*\\*5' earlier"):
        ex.define("T_bound=a_I**4")
    with pytest.raises(ValueError, match="built in"):
        unregister("D_I")


def test_jit_vmap_grad_through_the_measurement_model():
    """The expression effect behaves as a built-in: predict is jitted, vmapped over θ, and its derivative in the new
    coefficient is the expression itself (linear effect) — also with a set-up effect whose derivative passes
    through the expression's inputs (table tilt), compared with central differences."""
    plan = gj.plans.multiposition(24, minutes=0.1, dt_s=2)
    rec = gj.simulate(plan, {"coefficients": {"D_F": 0.1}}, seed=0)[0]
    data = record_data(rec)
    with ex.defined("T_grad=a_I**3 + sin(a_S)*w_I"):
        model = Model(("D_F", "D_I", "table_tilt", "T_grad"))
        theta = jnp.array([0.2, 0.5, 30.0, -20.0, 0.07])
        f = jax.jit(predict, static_argnums=0)
        y = f(model, theta, data)
        ys = jax.vmap(lambda th: predict(model, th, data))(jnp.stack([theta, 2 * theta]))
        np.testing.assert_allclose(ys[0], y, rtol=1e-12)
        jac = jax.jacfwd(lambda th: predict(model, th, data))(theta)
        x0 = predict(Model(("D_F",)), jnp.zeros(1), data)  # ω_I alone (no effect): the indicated rate
        from gyrojax.physics.model import instrument_inputs

        inp = instrument_inputs(
            data, {"delta": jnp.asarray([30.0, -20.0, 0.0]) * gj.units.ARCSEC, "encoder": jnp.zeros(4)}
        )
        np.testing.assert_allclose(jac[:, 4], inp["a_I"] ** 3 + np.sin(inp["a_S"]) * inp["w_I"], rtol=1e-10)
        h = 1e-3
        for k in (2, 3):
            e = jnp.zeros(5).at[k].set(h)
            fd = (predict(model, theta + e, data) - predict(model, theta - e, data)) / (2 * h)
            np.testing.assert_allclose(jac[:, k], fd, rtol=1e-5, atol=1e-12)
        assert np.all(np.isfinite(np.asarray(x0)))


def test_effects_files(tmp_path):
    toml = tmp_path / "lab.toml"
    toml.write_text('[effects]\nT_file3 = "a_I**3"\nT_file_t2 = { expr = "t_h**2", max = 0.01 }\n')
    assert ex.load_effects_file(toml) == ["T_file3", "T_file_t2"]
    assert ex.PLAUSIBLE_MAX["T_file_t2"] == 0.01
    js = tmp_path / "lab.json"
    js.write_text('{"effects": {"T_file3": "a_I**3"}}')
    assert ex.load_effects_file(js) == ["T_file3"]
    bad = tmp_path / "bad.toml"
    bad.write_text('[effects]\nT_bad = "a_I + os.system"\n')
    with pytest.raises(ex.ExpressionError, match=r"bad.toml: key 'effects.T_bad'.*'os.system'"):
        ex.load_effects_file(bad)
    (tmp_path / "none.toml").write_text("[other]\nx = 1\n")
    with pytest.raises(ex.ExpressionError, match="needs an 'effects' table"):
        ex.load_effects_file(tmp_path / "none.toml")
    for n in ("T_file3", "T_file_t2"):
        unregister(n)


def test_command_line_effect_simulate_fit_and_bad_token(tmp_path, capsys):
    """``--effect`` on simulate (the truth names its coefficient) and fit (appended to the terms); a bad token
    exits 2 with one line naming it."""
    import json

    from gyrojax.cli import main

    truth = tmp_path / "truth.json"
    truth.write_text(json.dumps({"coefficients": {"D_F": 0.3, "D_I": 0.5, "T_cli": 0.2}, "noise": {"white": 0.0005}}))
    try:
        argv = [
            "simulate",
            "multiposition",
            "-o",
            "n=24",
            "-o",
            "minutes=1",
            "-o",
            "dt_s=5",
            "--truth",
            str(truth),
            "--out",
            str(tmp_path / "run"),
            "--effect",
            "T_cli=a_S**3 + a_O",
        ]
        assert main(argv) == 0
        capsys.readouterr()
        rc = main(["fit", str(tmp_path / "run"), "--terms", "D_F,D_I", "--effect", "T_cli=a_S**3 + a_O", "--json"])
        out = json.loads(capsys.readouterr().out)
        assert rc == 0 and out["terms"] == ["D_F", "D_I", "T_cli"]
        c = out["coefficients"]["T_cli"]
        assert abs(c["value"] - 0.2) < 4 * c["std"] and c["unit"] == "deg/h per (a_S**3 + a_O)"
    finally:
        if "T_cli" in fx.names():
            unregister("T_cli")
    rc = main(["fit", str(tmp_path / "run"), "--effect", "T_bad=a_I + __import__('os')"])
    err = capsys.readouterr().err
    assert rc == 2 and err.count("\n") == 1 and "'__import__'" in err
    assert "T_bad" not in fx.names()
