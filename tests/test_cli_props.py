"""Property tests of the command line: random bad arguments to plan, sim, move and scan never
give a traceback or exit code 1; they give exit code 2 and one line naming the option.

Run in-process through ``robodcn.cli.main(argv)`` with stdout/stderr captured (fast); every
command that would touch a device gets one that does not exist, so an argument that slipped
past the checks would show up as exit code 4, not as motion.
"""

from __future__ import annotations

import contextlib
import io
import traceback
from pathlib import Path

from hypothesis import HealthCheck, given, settings
from hypothesis import strategies as st

from robodcn import cli

ROOT = Path(__file__).resolve().parent.parent
ARM3R = str(ROOT / "configs" / "arm3r.toml")
NO_DEVICE = "/nonexistent/ttyROBODCN"
MOVE = ("--arm", ARM3R, "--to", "0.12,0.24,60")
BASE = {
    "plan": ("plan", *MOVE),
    "sim": ("sim", *MOVE, "--timing", "fast"),
    "move": ("move", *MOVE, "--device", NO_DEVICE),
    "scan": ("scan", "--device", NO_DEVICE, "--ids", "1"),
}
MOTION = ("plan", "sim", "move")
SETTINGS = settings(max_examples=60, deadline=None, derandomize=True,
                    suppress_health_check=[HealthCheck.too_slow])


def run(argv: list[str]) -> tuple[int | None, str, str]:
    """(exit code, stdout, stderr) of ``main(argv)``; an exception escaping main fails."""
    out, err = io.StringIO(), io.StringIO()
    with contextlib.redirect_stdout(out), contextlib.redirect_stderr(err):
        try:
            code = cli.main(argv)
        except SystemExit as exc:
            code = exc.code
        except BaseException:  # what a user would see as a traceback
            raise AssertionError(f"{argv}: traceback\n{traceback.format_exc()}") from None
    return code, out.getvalue(), err.getvalue()


def assert_usage_error(argv: list[str], option: str) -> None:
    code, out, err = run(argv)
    lines = err.strip().splitlines()
    assert code == 2, (argv, code, err)
    assert len(lines) == 1 and lines[0].startswith("robodcn"), (argv, err)
    assert option in lines[0], (argv, option, err)
    assert "Traceback" not in err and out == "", (argv, out)


# -- bad values ----------------------------------------------------------------------------------

junk_text = st.text(st.characters(blacklist_categories=("Cs",), blacklist_characters="\x00"),
                    max_size=12)
unicode_digits = st.sampled_from(["١٢", "１２", "²", "½", "1_000", "0x10", "1e", "--", "٣.٥"])
non_finite = st.sampled_from(["nan", "NaN", "inf", "-inf", "+inf", "1e999", "-1e999",
                              "infinity"])
not_a_number = st.one_of(non_finite, unicode_digits,
                         junk_text.filter(lambda s: not _is_plain_number(s)))


def _is_plain_number(text: str) -> bool:
    try:
        value = float(text)
    except ValueError:
        return False
    return text.strip().isascii() and value == value and abs(value) != float("inf")


finite = st.floats(allow_nan=False, allow_infinity=False, width=32)
#: (option, bad value) pairs that no command may accept, per option.
NUMBERS = {
    "--rate": st.one_of(not_a_number, st.floats(max_value=0.999, allow_nan=False),
                        st.floats(min_value=1000.001, allow_nan=False)).map(str),
    "--beta": not_a_number,
    "--duration": st.one_of(not_a_number.filter(lambda s: s.strip() != "auto"),
                            st.floats(max_value=0.0, allow_nan=False).map(str),
                            st.floats(min_value=1e5, max_value=1e308).map(str)),
}
EXECUTION = {
    "--tracking-limit": st.one_of(not_a_number, st.floats(max_value=0.0, allow_nan=False)
                                  .map(str)),
    "--feedback-every": st.one_of(not_a_number, st.integers(max_value=-1).map(str),
                                  st.integers(min_value=10 ** 9, max_value=10 ** 30).map(str),
                                  finite.filter(lambda v: v != int(v)).map(str)),
}


def bad_pose() -> st.SearchStrategy[str]:
    number = finite.map(lambda v: f"{v:g}")
    wrong_count = st.lists(number, min_size=0, max_size=6).filter(
        lambda xs: len(xs) not in (3,)).map(",".join)
    bad_part = st.lists(st.one_of(number, not_a_number), min_size=3, max_size=3).filter(
        lambda xs: not all(_is_plain_number(x) for x in xs)).map(",".join)
    return st.one_of(wrong_count, bad_part)


CHOICES = {"--profile": ("optimal", "quintic", "trapezoid", "linear"), "--elbow": ("up", "down"),
           "--method": ("sclerp", "kenlerp", "seplerp", "dlb"),
           "--turn": ("shortest", "ccw", "cw"), "--format": ("table", "json", "csv"),
           "--timing": ("realistic", "fast"),
           "--log-level": ("debug", "info", "warning", "error", "critical")}
COMMANDS_OF = {"--format": ("plan",), "--timing": ("sim",), "--log-level": tuple(BASE)}


def unknown_choice(option: str) -> st.SearchStrategy[str]:
    allowed = {c.lower() for c in CHOICES[option]}
    return st.one_of(junk_text, st.sampled_from(["Sclerp ", "ßclerp", "up,down", "", "ＵＰ"])
                     ).filter(lambda s: s.strip().lower() not in allowed)


@SETTINGS
@given(command=st.sampled_from(MOTION), data=st.data())
def test_bad_numbers_are_usage_errors(command, data):
    options = {**NUMBERS, **(EXECUTION if command != "plan" else {})}
    option = data.draw(st.sampled_from(sorted(options)))
    value = data.draw(options[option])
    assert_usage_error([*BASE[command], f"{option}={value}"], option)


@SETTINGS
@given(command=st.sampled_from(MOTION), option=st.sampled_from(["--to", "--from", "--via"]),
       pose=bad_pose())
def test_bad_poses_are_usage_errors(command, option, pose):
    assert_usage_error([*BASE[command], f"{option}={pose}"], option)


@SETTINGS
@given(data=st.data())
def test_unknown_choices_are_usage_errors(data):
    option = data.draw(st.sampled_from(sorted(CHOICES)))
    command = data.draw(st.sampled_from(COMMANDS_OF.get(option, MOTION)))
    value = data.draw(unknown_choice(option))
    assert_usage_error([*BASE[command], f"{option}={value}"], option)


@SETTINGS
@given(command=st.sampled_from(tuple(BASE)), name=st.text("abcdefghijklmnopqrstuvwxyz-",
                                                          min_size=1, max_size=10))
def test_unknown_options_are_usage_errors(command, name):
    assert_usage_error([*BASE[command], f"--x-{name}"], f"--x-{name}")


@SETTINGS
@given(command=st.sampled_from(("move", "scan")), data=st.data())
def test_bad_bus_values_are_usage_errors(command, data):
    option, value = data.draw(st.one_of(
        st.tuples(st.just("--baud"), st.one_of(not_a_number, st.integers().filter(
            lambda b: b not in (9600, 57600, 115200, 1000000, 2000000, 3000000, 4000000,
                                4500000)).map(str))),
        st.tuples(st.just("--ids"), st.one_of(
            junk_text.filter(lambda s: not s.replace(",", "").replace("-", "").isdigit()),
            st.integers(min_value=253, max_value=10 ** 6).map(str),
            st.sampled_from(["1,,2-", "3-", "-", "1-2-3", "١"])))
        if command == "scan" else st.nothing()))
    assert_usage_error([*BASE[command], f"{option}={value}"], option)


def _bad_paths(tmp: Path) -> st.SearchStrategy[str]:
    return st.one_of(
        st.just(str(tmp)),  # a directory
        junk_text.filter(lambda s: "/" not in s and s not in ("", ".", "..")).map(
            lambda s: str(tmp / "missing" / s)),  # a directory that does not exist
        st.just("/proc/sys/robodcn.out"),  # read-only even for root
    )


@settings(max_examples=30, deadline=None, derandomize=True)
@given(command=st.sampled_from(("plan", "sim")), data=st.data())
def test_bad_output_paths_are_usage_errors(tmp_path_factory, command, data):
    tmp = tmp_path_factory.getbasetemp()
    option = "--out" if command == "plan" else "--plot"
    path = data.draw(_bad_paths(tmp))
    assert_usage_error([*BASE[command], option, path], option)


@SETTINGS
@given(command=st.sampled_from(MOTION), name=junk_text.filter(lambda s: s.strip() != ""))
def test_missing_arm_files_are_usage_errors(command, name):
    argv = [*BASE[command]]
    argv[argv.index("--arm") + 1] = f"/nonexistent/{name}.toml"
    assert_usage_error(argv, "--arm")
