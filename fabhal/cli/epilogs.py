"""The examples and explanations at the end of each command's `--help`."""

from __future__ import annotations

MAIN_EPILOG = """\
examples:
  fabhal solve {gallery}/mug_hanger.fhl       where every part ends up, hanging at rest
  fabhal solve --json -o out.json prog.fhl   the full result as JSON
  fabhal render {gallery}/mug_hanger.fhl -o mug.png   draw it (.png .html .glb .obj .stl)
  fabhal check {gallery}/mug_hanger.fhl       validate a program, report every problem
  fabhal check --json {gallery}/*.fhl         the same as a JSON array, for tools
  fabhal parts                               the part library, one line per part
  fabhal parts DoubleHook                    one part: primitives, DoFs, mass
  fabhal gallery                             the example hacks and reusable sub-assemblies
  fabhal search {gallery}/clip_light_family.fhl   every member of a family, solved and ranked
  fabhal watch my_hack.fhl                   solve on every save; a live view in the browser
  fabhal design {gallery}/specs/mug_under_rod.fhl --inventory {gallery}/specs/s_hooks.toml
                                             designs from the parts you own
  fabhal lsp                                 the language server, for your editor
  fabhal check --help                        more about one command

A program (.fhl) says what the hack hangs from (environment), what it holds
(target) and which connector of which part touches which (connect); the
solver works out where everything ends up. See docs/language.md.
The gallery programs above are installed with FabHaL in {gallery}/;
a program anywhere can `import "lib/s_hook_chain.fhl"` and the other
sub-assemblies that `fabhal gallery` lists.
"""


CHECK_EPILOG = """\
examples:
  fabhal check {gallery}/mug_hanger.fhl
  fabhal check {gallery}/*.fhl                check several files at once
  fabhal check --json my_hack.fhl | jq .     machine-readable diagnostics
  fabhal check -D n=3 -D Ring=RingM family.fhl   bind the program's `param`s

exit status: 0 no errors (warnings allowed), 1 errors found, 2 a file could
not be read (or an internal error).
Each diagnostic reads `file:line:col: error[CODE]: message` and ends with a
`help:` line; docs/errors.md explains every CODE with an example and a fix.
"""


PARTS_EPILOG = """\
examples:
  fabhal parts                      every part: its primitives and what it is
  fabhal parts DoubleHook           primitives with shape parameters, frames and
                                    degrees of freedom; mass, centre of mass, size
  fabhal parts ParamTurnbuckle --json

A part connects through its primitives: `connect s1.hook2 -- rod` uses the
primitive `hook2` of the part `s1`. Tags: UNBOUNDED (turns freely),
BOUNDED_AND_CLAMPED (stops at its ends), BOUNDED_AND_OPEN (past an end the
connection comes apart).
"""


SOLVE_EPILOG = """\
examples:
  fabhal solve {gallery}/mug_hanger.fhl
  fabhal solve --json {gallery}/bird_feeder.fhl      the result object on stdout
  fabhal solve -o result.json {gallery}/demo.fhl     ... or in a file
  fabhal solve --no-gravity my_hack.fhl             only step 1: closest to the target
  fabhal solve --two-step {gallery}/demo.fhl        the paper's two steps, without aiming
  fabhal solve --dofs {gallery}/demo.fhl            every degree of freedom: range, where it settled
  fabhal solve -D n=3 --seed 7 family.fhl           bind a param; another random start
  fabhal solve {gallery}/mug_hanger.fhl --render mug.png   ... and draw it (see `render`)

Step 1 moves the parts (through the connections' degrees of freedom) to bring
the target closest to its requested frame; step 2 lets the assembly settle
under gravity from there (clips and `fixed` connections hold; a part slides
along a rod, or over the floor it stands on, only where gravity beats
friction). Then the settings that stay put (where a clip grips a bar, where
a part sits on a rod that friction holds) are aimed: chosen again so that the
settled target hangs nearest the request (note N506 lists them; --two-step
keeps step 1's; a setting written in the program, `set (hanger.rod.t: 0.47)`
on its connection, is held as written). A connection written with neither
`flip` nor `noflip` is turned over where the default way round does not hang
at rest, or hangs but the parts cannot reach the requested position, and
turned over it hangs (nearer): note N507 says so. If a connection would slide
off an open end, or an object fall over on its floor or its round feet, from
every start tried, the status is `falls_apart` and the message names the
connection; a result that is not verified at rest (E503; an object sliding on
its feet, E510; a ring the model holds still that would turn about its own
wire in a hook, E513), or where parts lie inside each other or the world, or
in one place (E508), has the status `not_at_rest`.

--time-limit bounds the whole command (checking included): at the limit the
best result so far is reported, with warning W502; if the loops of the design
are not even closed by then, the status is `out_of_time`. It does not bound
measuring a part's shape for contact (up to 10 s, once per machine, said on
the progress line as it happens).

exit status: 0 solved, 1 falls apart / not at rest / infeasible / out of time / errors in
the program, 2 a file could not be read (or an internal error).
"""


RENDER_EPILOG = """\
examples:
  fabhal render {gallery}/mug_hanger.fhl -o mug.png          a picture (no display needed)
  fabhal render {gallery}/mug_hanger.fhl -o mug.png --views iso,front,side
  fabhal render {gallery}/bird_feeder.fhl -o feeder.html     open in a browser: orbit, zoom, hover
  fabhal render {gallery}/demo.fhl -o demo.glb --primitives  3D file for Blender, a CAD tool, ...
  fabhal render my_hack.fhl -o before.png --show requested  ghost of the target where you asked for it
  fabhal solve {gallery}/mug_hanger.fhl --render mug.png     solve, report and render in one go

The suffix of OUT picks the format: .png (three-quarter view, optionally front,
side and top views; parts labelled; the requested target frame as long axes,
the achieved one as short axes), .html (one self-contained page, works
offline), .glb / .obj / .stl (one node per part at its solved frame;
environments grey, the target orange). `--show requested` adds a see-through
copy of the target at its requested frame and, when the design falls apart,
a red ball on the connection that comes apart.

exit status: 0 solved and written, 1 the design falls apart or cannot be
solved (a falling design is still drawn), 2 a file could not be read or written.
"""


BENCH_EPILOG = """\
examples:
  fabhal bench                          every program in {gallery}/, 5 runs each
  fabhal bench -n 1 --no-process        a quick look: one run, no separate processes
  fabhal bench {gallery}/mug_hanger.fhl  one program
  python bench/run.py                   the same from a checkout

Per program: parse, check and solve times (median over the runs in one
process, round robin over the programs; the first includes importing the
solver), the wall time of whole `fabhal solve` processes (median of 3 with
Python's bytecode cache filled, as from a second run on; and one cold,
compiling fabhal first), and whether the targets are met: a process under 1 s,
the solve step under 200 ms (500 ms for programs with loops). The four
clip-light programs also run back to back as one row. Writes bench/results.json
when run from a checkout (or -o FILE). See bench/README.md.
"""


SEARCH_EPILOG = """\
examples:
  fabhal search {gallery}/clip_light_family.fhl        all 336 members, on every core
  fabhal search {gallery}/clip_light_family.fhl -D ring=RingS -D n=4   hold params: one row of it
  fabhal search family.fhl --sample 40 --seed 3        a random 40 of the members
  fabhal search family.fhl --inventory mine.toml       only what you own (`DoubleHook = 4` lines)
  fabhal search family.fhl --emit best/ --render best/ --plot errors.png
  fabhal search family.fhl --resume                    go on after an interruption
  fabhal search family.fhl --smooth                    neighbours share their settings: no jumps
  fabhal search family.fhl --executor dask://10.0.0.5:8786   on a Dask cluster

A family is every combination of the values of the program's `param`s
(`param n in 1 .. 4`, `param e in linspace(0, 45.7, 21)`, `param ring in
[RingS, RingM]`). Each member is checked (members the check or the inventory
rejects are counted by reason, with one example each), the rest are solved in
parallel and ranked: those that hang at rest by where the target settles
(position error, then rotation), then by number of parts. With a param whose
values are part types, the best member for each of them is reported too.

Every result is appended to the log (--log, default NAME.search.jsonl in the
working directory) as it finishes; after Ctrl-C, `--resume` solves only what
is missing. --emit writes the best members as programs with their params
bound (`fabhal solve` gives the same answer); --render draws them and a contact
sheet of them side by side; --plot draws the target error against the params.

Each member is solved on its own, so where the solver's choices (where a clip
grips a bar, where a hook sits on a rod) land in another valley, neighbouring
members can hang far apart. --smooth also solves each member from the solved
configuration of the member beside it (the previous and the next value of the
last param) and keeps whichever hangs nearer: a builder could reuse those
settings. Such a member's emitted program says so and lists the settings to
build; `fabhal solve` on it alone starts afresh and may settle elsewhere.

Dask: `pip install 'fabhal[dask]'` where you run this and on the workers,
start `dask scheduler` and `dask worker HOST:8786` (FabHaL must be importable
by every worker), then pass --executor dask://HOST:8786.

exit status: 0 at least one member hangs at rest, 1 none does (or the
program has errors), 2 a file could not be read or written (or an internal error).
"""


WATCH_EPILOG = """\
examples:
  fabhal watch my_hack.fhl                 solve on every save; open the address it prints
  fabhal watch my_hack.fhl --port 8765     a fixed port
  fabhal watch family.fhl -D n=3           one member of a family

Edit the program in any editor: each save of it (or of a file it imports)
checks and solves it again, and the page shows the new result in place
(the camera stays where you left it), with the status and the target error.
When a save has errors, the page keeps showing the last result that solved,
with the errors over it: click one to see its line. A solve still running
when a newer save arrives is abandoned. The terminal prints one line per
solve. The server listens on 127.0.0.1 only; Ctrl-C stops it.

exit status: 0 stopped with Ctrl-C, 2 the program could not be read at the
start, or the port is taken.
"""


DESIGN_EPILOG = """\
examples:
  fabhal design spec.fhl --inventory mine.toml                 the best designs from what you own
  fabhal design spec.fhl --inventory mine.toml --emit designs/ --render designs/
  fabhal design spec.fhl --inventory mine.toml --max-parts 3 --budget 20 --time-limit 30

The spec is a program with the environment(s) and the target (the object
to hang, with `target ... at ...`) and no connections; the inventory is a
TOML file, one `PartType = count` line per part you own (the format of
`fabhal search --inventory`). FabHaL grows every design those parts allow:
chains that hang the target from one support, and two-point hangs (a part
with three or more connectors, e.g. a hanger, hung from two supports by two
chains). Each connection is tried against the checker's rules as the design
grows (E401, E402, E404), a two-point hang whose chains cannot span its
supports is dropped (E420), and so is a chain too short to reach. The most
promising (--budget, by where chains hanging straight down would leave the
target) are solved in parallel and ranked by settled target error, then by
number of parts. --emit writes each as a program (`fabhal solve` reproduces
it exactly); --render draws them and a contact sheet.

exit status: 0 a design settles within --tolerance of the target, 1 none
does (the closest is reported), 2 a file could not be read.
"""


LSP_EPILOG = """\
Point your editor's LSP client at the command `fabhal lsp` for files ending
in .fhl. It reports `fabhal check`'s diagnostics as you type (the same codes,
spans and help), shows a part type's primitives, DoFs and mass on hover (and
a primitive's, on `s1.hook2`), completes part types, keywords and, after
`name.`, that part's primitives, jumps to the definition of a part type, an
assembly, a name or an imported file, and lists the program's symbols.

Neovim:   vim.lsp.start({ name = "fabhal", cmd = { "fabhal", "lsp" } })
Helix:    [language-server.fabhal] command = "fabhal", args = ["lsp"]
VS Code:  editors/vscode/ highlights .fhl; any generic LSP client extension
          can run `fabhal lsp`.
"""


GALLERY_EPILOG = """\
examples:
  fabhal gallery                               every program and sub-assembly, with what it is
  fabhal solve {gallery}/mug_hanger.fhl          solve one of them where it is installed
  cp {gallery}/mug_hanger.fhl my_hack.fhl        ... or copy it and make it yours

In your own program, `import "lib/s_hook_chain.fhl"` (or any lib/ file listed)
makes its assembly available: an import is looked up next to the importing
file, then in the part library, then in the gallery.
"""
