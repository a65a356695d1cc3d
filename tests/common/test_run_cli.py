"""run_cli: the exit statuses and one-line messages its docstring documents."""

import pytest

from drivestyle.common.cli import run_cli
from drivestyle.common.output_paths import OutputPathError


def _raises(exc: BaseException):
    def main(argv):
        raise exc

    return main


@pytest.mark.parametrize(
    "exc",
    [
        ValueError("risk must lie in (0, 1)"),
        OutputPathError("--out x exists and is not a folder"),
        FileNotFoundError("demonstration not found: x.npz"),
        RuntimeError("the solver could not start"),
    ],
    ids=["ValueError", "OutputPathError", "FileNotFoundError", "RuntimeError"],
)
def test_bad_input_exits_2_with_one_error_line(exc, capsys, monkeypatch):
    monkeypatch.delenv("DRIVESTYLE_TRACEBACK", raising=False)
    with pytest.raises(SystemExit) as info:
        run_cli(_raises(exc), [])
    assert info.value.code == 2
    assert capsys.readouterr().err == f"error: {exc}\n"


def test_an_unexpected_error_exits_1(capsys, monkeypatch):
    monkeypatch.delenv("DRIVESTYLE_TRACEBACK", raising=False)
    with pytest.raises(SystemExit) as info:
        run_cli(_raises(KeyError("oops")), [])
    assert info.value.code == 1
    err = capsys.readouterr().err.strip().splitlines()
    assert len(err) == 1 and err[0].startswith("error: unexpected KeyError")


def test_ctrl_c_exits_130(capsys):
    with pytest.raises(SystemExit) as info:
        run_cli(_raises(KeyboardInterrupt()), [])
    assert info.value.code == 130 and "interrupted" in capsys.readouterr().err


@pytest.mark.parametrize(
    ("signal_exc", "code"), [(KeyboardInterrupt(), 130), (SystemExit(143), 143)]
)
def test_a_signal_wrapped_by_a_c_extension_is_that_signal(signal_exc, code, capsys):
    # CasADi returns from a call whose signal handler raised; Python then raises SystemError
    # from the handler's exception (Ctrl-C, or SIGTERM's SystemExit)
    def main(argv):
        try:
            raise signal_exc
        except BaseException as exc:
            raise SystemError(
                "<built-in function f> returned a result with an exception set"
            ) from exc

    with pytest.raises(SystemExit) as info:
        run_cli(main, [])
    assert info.value.code == code and "unexpected" not in capsys.readouterr().err


def test_success_and_explicit_exits_pass_through():
    run_cli(lambda argv: None, [])
    with pytest.raises(SystemExit) as info:
        run_cli(_raises(SystemExit(3)), [])
    assert info.value.code == 3


def test_traceback_on_request(monkeypatch):
    monkeypatch.setenv("DRIVESTYLE_TRACEBACK", "1")
    with pytest.raises(ValueError, match="shown"):
        run_cli(_raises(ValueError("shown")), [])


def test_ctrl_c_says_what_a_command_kept():
    import io
    from contextlib import redirect_stderr

    from drivestyle.common.cli import Interrupted

    err = io.StringIO()
    with redirect_stderr(err), pytest.raises(SystemExit) as info:
        run_cli(_raises(Interrupted("3 finished row(s) kept in out/styles.csv")), [])
    assert info.value.code == 130
    assert err.getvalue() == "\ninterrupted: 3 finished row(s) kept in out/styles.csv\n"
    err = io.StringIO()
    with redirect_stderr(err), pytest.raises(SystemExit):
        run_cli(_raises(KeyboardInterrupt()), [])
    assert err.getvalue() == "\ninterrupted: unfinished output was discarded\n"
