"""Elaboration: params, loops, indexed names, sub-assemblies and name resolution."""

from __future__ import annotations

from pathlib import Path

import pytest

from fabhal import api
from fabhal.diagnostics import render_all
from fabhal.elaborate import FlatProgram
from tests.conftest import assert_golden

GOLDEN = Path(__file__).parent / "elaborate_golden"

CHAIN = """\
param n in 1 .. 4 = 3
param ext in linspace(0, 45.7, 21) = 22.85
param Ring in [RingXS, RingS, RingM, RingL] = RingS

environment ceiling = CeilingHook() at (0, 0, 1000)
clip = ClipLight()
link = ceiling.hook
for i in 1 .. n {
  tb[i] = ParamTurnbuckle(extension: ext)
  r[i]  = Ring()
  connect tb[i].hook1 -- link
  connect r[i].ring -- tb[i].hook2
  link = r[i].ring
}
hanger = FabricHanger()
connect hanger.hook1 -- link flip
connect clip.clip -- hanger.rod fixed
target clip.clip at (0, 0, 0) rot (180, 90, 0)
"""


def flat(tmp_path: Path, text: str, **bindings: str) -> FlatProgram:
    program = tmp_path / "p.fhl"
    program.write_text(text)
    result = api.check(program, bindings)
    assert result.ok, result.diagnostics
    assert result.flat is not None
    return result.flat


def test_loops_unroll_into_indexed_parts(tmp_path: Path) -> None:
    program = flat(tmp_path, CHAIN)
    names = [p.name for p in program.parts]
    assert names == ["ceiling", "clip", "tb[1]", "r[1]", "tb[2]", "r[2]", "tb[3]", "r[3]", "hanger"]
    assert {p.type_name for p in program.parts if p.name.startswith("r[")} == {"RingS"}
    assert program.part("ceiling").environment and program.part("ceiling").position == (0.0, 0.0, 1000.0)
    # the alias `link` walks down the chain
    firsts = [(str(c.a), str(c.b)) for c in program.connections]
    assert firsts[:3] == [
        ("tb[1].hook1", "ceiling.hook"),
        ("r[1].ring", "tb[1].hook2"),
        ("tb[2].hook1", "r[1].ring"),
    ]
    assert firsts[-2] == ("hanger.hook1", "r[3].ring")
    assert program.connections[-2].flip and program.connections[-1].fixed
    (target,) = program.targets
    assert (target.part, target.primitive, target.rotation) == ("clip", "clip", (180.0, 90.0, 0.0))


def test_parameters_bind_from_the_command_line(tmp_path: Path) -> None:
    program = flat(tmp_path, CHAIN, n="2", ext="4.57", Ring="RingL")
    assert sum(p.name.startswith("tb[") for p in program.parts) == 2
    assert program.part("r[2]").type_name == "RingL"
    # the turnbuckle's hooks moved apart with the extension: y = 43.5 + e / 2
    hook1 = program.part("tb[1]").spec.primitive("hook1")
    assert hook1 is not None and abs(hook1.position[1] - (43.5 + 4.57 / 2)) < 1e-12


def test_sub_assemblies_expand_with_prefixed_names(tmp_path: Path) -> None:
    text = """\
assembly SHookChain(n: 1 .. 5 = 2) "n S-hooks" {
  for i in 1 .. n {
    s[i] = DoubleHook()
  }
  for i in 2 .. n {
    connect s[i].hook2 -- s[i - 1].hook1
  }
  port top = s[1].hook2
  port bottom = s[n].hook1
}
environment rod = Rod(length: 500, radius: 2) at (0, 0, 200) rot (90, 0, 90)
chain = SHookChain(n: 3)
mug = Mug()
connect chain.top -- rod
connect mug.hook -- chain.bottom
target mug.hook at (0, 0, 50)
"""
    program = flat(tmp_path, text)
    assert [p.name for p in program.parts] == ["rod", "chain.s[1]", "chain.s[2]", "chain.s[3]", "mug"]
    pairs = [(str(c.a), str(c.b)) for c in program.connections]
    assert pairs == [
        ("chain.s[2].hook2", "chain.s[1].hook1"),
        ("chain.s[3].hook2", "chain.s[2].hook1"),
        ("chain.s[1].hook2", "rod"),
        ("mug.hook", "chain.s[3].hook1"),
    ]


MISTAKES = {
    "unknown_part_type": "s1 = DoubleHoook()\n",
    "unknown_name": "environment rod = Rod(length: 500, radius: 2) at (0, 0, 200)\ns1 = DoubleHook()\n"
    "connect s2.hook2 -- rod\n",
    "duplicate_name": "s1 = DoubleHook()\ns1 = DoubleHookMedium()\n",
    "unknown_primitive": "environment rod = Rod(length: 500, radius: 2) at (0, 0, 200)\ns1 = DoubleHook()\n"
    "connect s1.hook3 -- rod\n",
    "which_primitive": "environment rod = Rod(length: 500, radius: 2) at (0, 0, 200)\ns1 = DoubleHook()\n"
    "connect s1 -- rod\n",
    "used_before_declared": "environment rod = Rod(length: 500, radius: 2) at (0, 0, 200)\n"
    "connect s1.hook2 -- rod\ns1 = DoubleHook()\n",
    "bad_part_argument": "tb = ParamTurnbuckle(extension: 60)\n",
    # one mistake in a declaration is one error, not one more at every later use of the name
    "broken_declaration_used_later": "environment rod = Rod(length: 500, radius: 2) at (0, 0, 200)\n"
    "tb = ParamTurnbuckle(extension: 60)\nconnect tb.hook1 -- rod\ntarget tb.hook2 at (0, 0, 100)\n",
    "unknown_part_argument": "tb = ParamTurnbuckle(extention: 10)\n",
    "param_without_value": "param n in 1 .. 4\n",
    "param_outside_domain": "param n in 1 .. 4 = 7\n",
    "bare_primitive_component": "rod = Rod(length: 300, radius: 6)\n",
    "fractional_loop": "for i in 1 .. 2.5 {\n  s[i] = DoubleHook()\n}\n",
    "target_in_assembly": "assembly Hanging {\n  s = DoubleHook()\n  target s.hook1 at (0, 0, 0)\n}\n"
    "hanging = Hanging()\n",
    "primitive_of_alias": "s1 = DoubleHook()\ntop = s1.hook1\ns2 = DoubleHook()\n"
    "connect s2.hook2 -- top.hook1\n",
    "several_name_errors": "s1 = DoubleHook()\nconnect s1.hook9 -- s2.hook1\nm = Mugg()\n",
    # a name misspelt where its declaration failed: still suggested (was "declared so far: s")
    "misspelt_broken_name": "s = DoubleHook()\nmug = Mugg()\nconnect mug.hook -- s.hook2\n"
    "target mugg at (0, 0, 1800)\n",
    "both_alignments": "s1 = DoubleHook()\ns2 = DoubleHook()\nconnect s2.hook2 -- s1.hook1 flip noflip\n",
    # each wrong `set (...)`: another connection's side, a DoF the hook lacks, a value
    # outside the hook's arc (0 .. 270 degrees), one DoF twice; a setting of a free
    # turn (the rod's spin) takes any angle
    "setting_mistakes": "environment rod = Rod(length: 500, radius: 2) at (0, 0, 200)\n"
    "s1 = DoubleHook()\ns2 = DoubleHook()\nconnect s1.hook2 -- rod set (s2.hook1.theta: 90)\n"
    "connect s2.hook2 -- s1.hook1 set (s1.hook1.t: 0.5, s2.hook2.theta: 300)\n"
    "connect s2.hook1 -- rod set (rod.t: 0.2, rod.t: 0.3, rod.spin: 720)\n",
    # a flex angle set past where its wire jams: the S-hook (9.6 mm inside) on the mug's
    # 6 mm handle jams at acos(sqrt(6 / 9.6)) = 37.76 degrees, so 130 lies outside 52.24 .. 127.76
    "setting_past_a_jam": "environment rod = Rod(length: 500, radius: 2) at (0, 0, 200)\n"
    "s1 = DoubleHook()\nmug = Mug()\nconnect s1.hook2 -- rod\n"
    "connect mug.hook -- s1.hook1 set (s1.hook1.phi: 130)\n",
    # the library's rings keep their contact on the inner line: no spin without the flag
    "spin_without_the_flag": "environment rod = Rod(length: 500, radius: 2) at (0, 0, 200)\n"
    "s1 = DoubleHook()\nfeeder = BirdFeeder()\nconnect s1.hook2 -- rod\n"
    "connect feeder.ring -- s1.hook1 set (feeder.ring.spin: 30)\n",
}


@pytest.mark.parametrize("name", sorted(MISTAKES))
def test_name_mistakes_are_located(name: str, monkeypatch: pytest.MonkeyPatch) -> None:
    monkeypatch.chdir(GOLDEN)
    program = GOLDEN / f"{name}.fhl"
    program.write_text(MISTAKES[name])
    result = api.check(Path(program.name))
    assert not result.ok
    assert all(d.span is not None for d in result.diagnostics)
    assert_golden(render_all(result.diagnostics, result.sources) + "\n", program.with_suffix(".txt"))


def test_unknown_definition_binding_is_reported(tmp_path: Path) -> None:
    program = tmp_path / "p.fhl"
    program.write_text("param n in 1 .. 4 = 2\n")
    result = api.check(program, {"m": "3"})
    assert [d.code for d in result.diagnostics] == ["E310"]
    assert "has no `param m`" in result.diagnostics[0].message
