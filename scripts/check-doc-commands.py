#!/usr/bin/env python3
"""Run every `isomarch ...` command that the documentation shows, at a small size.

Not part of the test suite: a manual check that the commands in README.md and
docs/*.md still parse and run. It collects

  - lines of fenced ```sh blocks (and of unlabelled ``` blocks) that run
    isomarch, with `\\` continuations joined and `# comments` dropped;
  - inline code spans that start with `isomarch ` (a span may wrap across lines
    of a paragraph: its lines are joined).

Each command is shrunk so that the whole run takes minutes: --size at most 64
pixels a side (aspect kept; render without --size gets 64x64), --rays at most
2048 (bench and scaling get --rays 2048 when they have none), --repeat 1,
--frames a..b becomes its first 2 frames, bench --camera-rays WxH becomes 64x64,
scaling keeps its two smallest --counts, tradeoff gets --quick --rays 256.

Commands run from the repository root with the release binary in place of
`isomarch`, a timeout of 120 s each, and every relative output path (-o,
--heatmap, --stats, --json, --csv, --aov-output, --heatmap-grid, ...) moved
into a fresh temporary folder of its own, shown as $OUT (so batches do not
share out/frames.csv). A relative input that is not in the repository but
that an earlier command wrote (out/p1000.ron) is read from that command's
folder (encode's frame pattern, out/frame_####.png, from the folder of an
earlier command that wrote such frames); tradeoff --replot gets a copy of the
folder it replots. Identical commands run once.
Skipped, with the reason: `view` (needs a display), commands with placeholders
(SCENE, FILE, M, ..., $v, <x>, [a | b]), spans missing required arguments, and
inputs made by something other than isomarch (globs that match nothing).

Usage: python3 scripts/check-doc-commands.py [--list] [--only PATTERN] [--bin PATH] [--keep]
Exits 1 if any command fails.
"""

import argparse
import glob
import os
import re
import shlex
import shutil
import subprocess
import sys
import tempfile
import time
from pathlib import Path

ROOT = Path(__file__).resolve().parent.parent
DEFAULT_BIN = Path.home() / ".cache/isomarch-target/release/isomarch"
TIMEOUT = 120
MAX_SIDE = 64
MAX_RAYS = 2048
OUTPUT_FLAGS = {"output", "heatmap", "stats", "json", "csv", "aov-output",
                "heatmap-grid", "screenshot", "screenshot-dir"}
KNOWN = {"render", "view", "info", "tradeoff", "bench", "generate", "scene",
         "scaling", "merge-stats", "frames", "encode"}
SHELL_LANGS = {"", "sh", "bash", "shell", "console"}
# A capitalised word as a whole path component (SCENE, scenes/SCENE.ron, M),
# an ellipsis, a shell variable, <x>, [optional | alternative].
PLACEHOLDER = re.compile(r"(^|[/=,])[A-Z][A-Z_]*(?=$|[./,])|\.\.\.|\$|[<>\[\]|]")


# ---------------------------------------------------------------- extraction

def is_isomarch(tok):
    return tok == "isomarch" or tok.endswith("/isomarch")


def extract(path):
    """Yield (line number, command text) for one Markdown file."""
    lines = path.read_text(encoding="utf-8").splitlines()
    fence, prose = None, []  # prose: (line number, text) outside fences
    i = 0
    while i < len(lines):
        line = lines[i]
        m = re.match(r"^\s*```+\s*(\S*)", line)
        if m:
            fence = None if fence is not None else m.group(1).lower()
            prose.append((i + 1, ""))  # a fence ends a paragraph
            i += 1
            continue
        if fence is None:
            prose.append((i + 1, line))
            i += 1
            continue
        start, text = i + 1, line
        while text.rstrip().endswith("\\") and i + 1 < len(lines):
            i += 1
            text = text.rstrip()[:-1] + " " + lines[i].strip()
        i += 1
        if fence in SHELL_LANGS:
            text = re.sub(r"(^|\s)#.*$", "", text).strip()
            try:
                toks = shlex.split(text)
            except ValueError:
                continue
            pre = toks[:next((k for k, t in enumerate(toks) if is_isomarch(t)), 0)]
            if toks and any(is_isomarch(t) for t in toks) and all("=" in t for t in pre):
                yield start, text
    # Inline spans: paragraphs are runs of non-blank prose lines.
    para = []
    for num, line in prose + [(0, "")]:
        if line.strip():
            para.append((num, line))
            continue
        if para:
            text = "\n".join(l for _, l in para)
            for m in re.finditer(r"(?<!`)`([^`]+)`(?!`)", text):
                span = " ".join(m.group(1).split())
                # `isomarch bench` alone names a command; it does not show one.
                if re.match(r"^(\w+=\S*\s+)*isomarch\s", span) and not re.fullmatch(
                        r"isomarch (generate \w+|[\w-]+)", span):
                    num0 = para[text.count("\n", 0, m.start())][0]
                    yield num0, span
        para = []


# ---------------------------------------------------------------- --help

class Help:
    """Options of one subcommand, from its --help: values, shorts, usage."""

    def __init__(self, binary, sub):
        out = subprocess.run([binary, *sub, "--help"], capture_output=True,
                             text=True, timeout=30).stdout
        self.takes = {}      # long name -> None | "required" | "optional"
        self.short = {}      # "o" -> "output"
        self.default = {}
        for m in re.finditer(r"^\s+(?:-(\w), )?--([\w-]+)( \[?<)?(.*)$", out, re.M):
            value = m.group(3)
            self.takes[m.group(2)] = None if not value else (
                "optional" if "[" in value else "required")
            if m.group(1):
                self.short[m.group(1)] = m.group(2)
            d = re.search(r"\[default: ([^\]]+)\]", m.group(4))
            if d:
                self.default[m.group(2)] = d.group(1)
        usage = re.search(r"^Usage: \S+ (.*)$", out, re.M).group(1).split()
        usage = usage[len(sub):]
        self.required_opts = [t[2:] for t in usage if t.startswith("--")]
        self.required_pos = sum(1 for k, t in enumerate(usage)
                                if t.startswith("<") and not usage[k - 1].startswith("-"))


def parse(tokens, helper):
    """Split arguments into items ['pos', value] and ['opt', name, spelled, value]."""
    items, unknown, k = [], [], 0
    while k < len(tokens):
        t = tokens[k]
        if t.startswith("-") and len(t) > 1:
            spelled, _, inline = t.partition("=")
            name = (helper.short.get(spelled[1:]) if not spelled.startswith("--")
                    else spelled[2:])
            if name not in helper.takes:
                unknown.append(spelled)
                items.append(["opt", spelled.lstrip("-"), spelled, None])
            else:
                kind, value = helper.takes[name], inline or None
                nxt = tokens[k + 1] if k + 1 < len(tokens) else None
                if value is None and nxt is not None and (
                        kind == "required" or
                        (kind == "optional" and re.fullmatch(r"\d+x\d+", nxt))):
                    value, k = nxt, k + 1
                items.append(["opt", name, spelled, value])
        else:
            items.append(["pos", t])
        k += 1
    return items, unknown


# ---------------------------------------------------------------- shrinking

def shrink_size(value):
    w, h = (int(x) for x in value.lower().split("x"))
    s = min(1.0, MAX_SIDE / max(w, h))
    return f"{max(1, round(w * s))}x{max(1, round(h * s))}"


def shrink_frames(value):
    m = re.fullmatch(r"(\d+)\.\.(=?)(\d+)", value)
    if not m:
        return value
    a, b = int(m.group(1)), int(m.group(3)) + (1 if m.group(2) else 0)
    return f"{a}..{min(b, a + 2)}"


def find_input(p, earlier):
    """Paths matching relative input p: in the repository, else in the output
    folder of the latest earlier command that wrote it."""
    for base in [ROOT, *earlier]:
        found = sorted(glob.glob(glob.escape(str(base)) + "/" + p))
        if found:
            return found
    return []


def prepare(cmd, binary, out, earlier, helps):
    """Return (argv, env, skip reason or None, notes) for one doc command:
    outputs go to the folder out; inputs may come from the folders earlier."""
    toks = shlex.split(cmd)
    at = next(k for k, t in enumerate(toks) if is_isomarch(t))
    env = dict(t.split("=", 1) for t in toks[:at])
    args = toks[at + 1:]
    notes = []
    if not args:
        return None, env, "no subcommand", notes
    sub = args[:2] if args[0] == "generate" and len(args) > 1 else args[:1]
    rest = args[len(sub):]
    if sub[0] not in helps:
        helps[sub[0]] = Help(binary, sub) if sub[0] in KNOWN else None
    helper = helps[sub[0]]
    if helper is None:
        return None, env, f"unknown subcommand {sub[0]!r}", notes
    items, unknown = parse(rest, helper)
    if unknown:
        notes.append("flags not in --help: " + " ".join(unknown))
    words = [t.split("=", 1)[1] for t in toks[:at]] + sub + rest
    placeholders = [t for t in words if PLACEHOLDER.search(t)]
    if placeholders:
        return None, env, "placeholder " + " ".join(placeholders), notes
    if sub[0] == "view":
        return None, env, "view needs a display", notes
    names = {it[1] for it in items if it[0] == "opt"}
    missing = [f"--{o}" for o in helper.required_opts if o not in names]
    npos = sum(1 for it in items if it[0] == "pos")
    if npos < helper.required_pos:
        missing.append(f"{helper.required_pos - npos} positional argument(s)")
    if missing:
        return None, env, "incomplete, missing " + ", ".join(missing), notes

    def add(name, value):
        items.append(["opt", name, f"--{name}", value])

    for it in items:
        if it[0] == "pos":
            p = it[1]
            if os.path.isabs(p) or (ROOT / p).exists():
                continue
            if "#" in p:
                # encode's frame pattern: the folder an earlier command
                # wrote the frames in, if one did.
                folders = [base for base in earlier if glob.glob(glob.escape(str(base)) + "/" + p.replace("#", "[0-9]"))]
                if not folders:
                    return None, env, f"no frames {p} (written outside these commands)", notes
                it[1] = str(folders[0] / p)
                continue
            found = find_input(p, earlier)
            if any(c in p for c in "*?[") and not found:
                return None, env, f"no file matches {p} (made outside isomarch)", notes
            if found:
                it[1] = found
            continue
        name, value = it[1], it[3]
        if value is None:
            continue
        if name in OUTPUT_FLAGS and not os.path.isabs(value):
            if sub[0] == "tradeoff" and "replot" in names and find_input(value, earlier):
                shutil.copytree(find_input(value, earlier)[0], out / value, dirs_exist_ok=True)
            it[3] = str(out / value)
        elif name == "size" or (name == "camera-rays" and sub[0] == "bench"):
            it[3] = shrink_size(value)
        elif name == "rays":
            it[3] = str(min(int(value), MAX_RAYS if sub[0] != "tradeoff" else 256))
        elif name == "repeat":
            it[3] = "1"
        elif name == "frames":
            it[3] = shrink_frames(value)
        elif name == "counts":
            it[3] = ",".join(str(c) for c in sorted(int(x) for x in value.split(","))[:2])
    if sub[0] in ("render", "view") and "size" not in names:
        add("size", f"{MAX_SIDE}x{MAX_SIDE}")
    if sub[0] == "bench" and "heatmap-grid" in names and "size" not in names:
        add("size", f"{MAX_SIDE}x{MAX_SIDE}")
    if sub[0] in ("bench", "scaling", "tradeoff") and not names & {"rays", "replot"}:
        add("rays", str(MAX_RAYS if sub[0] != "tradeoff" else 256))
    if sub[0] == "scaling":
        if "repeat" not in names:
            add("repeat", "1")
        if "counts" not in names:
            counts = sorted(int(x) for x in helper.default["counts"].split(","))
            add("counts", ",".join(map(str, counts[:2])))
        if "output" not in names:
            add("output", str(out / helper.default.get("output", "scaling")))
    if sub[0] == "tradeoff":
        if "quick" not in names and "replot" not in names:
            add("quick", None)
        if "output" not in names:
            scene = next(it[1] for it in items if it[0] == "pos")
            suffix = "-any-hit" if "any-hit" in names else ""
            add("output", str(out / f"tradeoff-{Path(scene).stem}{suffix}"))
    argv = [str(binary), *sub]
    for it in items:
        if it[0] == "pos":
            argv += it[1] if isinstance(it[1], list) else [it[1]]
        else:
            argv += [it[2]] + ([it[3]] if it[3] is not None else [])
    return argv, env, None, notes


# ---------------------------------------------------------------- main

def shown(argv, binary, out, tmp, env):
    s = " ".join(a if " " not in a else shlex.quote(a) for a in argv)
    s = s.replace(str(binary), "isomarch", 1).replace(str(out) + "/", "$OUT/").replace(str(tmp) + "/", "$TMP/")
    return " ".join(f"{k}={v}" for k, v in env.items()) + (" " if env else "") + s


def main():
    ap = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    ap.add_argument("--list", action="store_true", help="only print what would run")
    ap.add_argument("--only", metavar="PATTERN",
                    help="regex on 'file:line command'; only matching commands")
    ap.add_argument("--bin", type=Path, default=DEFAULT_BIN)
    ap.add_argument("--keep", action="store_true", help="keep the temporary folder")
    opts = ap.parse_args()
    if not opts.bin.exists():
        sys.exit(f"no binary at {opts.bin}")
    tmp = Path(tempfile.mkdtemp(prefix="isomarch-doc-"))
    files = [ROOT / "README.md", *sorted((ROOT / "docs").glob("*.md"))]
    helps, done, earlier, counts = {}, {}, [], {"OK": 0, "FAIL": 0, "SKIP": 0}
    t_start = time.monotonic()
    try:
        for path in files:
            rel = path.relative_to(ROOT)
            for line, cmd in extract(path):
                where = f"{rel}:{line}"
                if opts.only and not re.search(opts.only, f"{where} {cmd}"):
                    continue
                out = tmp / f"{len(earlier):03}"
                argv, env, skip, notes = prepare(cmd, opts.bin, out, earlier, helps)
                note = f"  [{'; '.join(notes)}]" if notes else ""
                if skip:
                    counts["SKIP"] += 1
                    print(f"SKIP {where}: {cmd}  ({skip}){note}")
                    continue
                text = shown(argv, opts.bin, out, tmp, env)
                if opts.list:
                    print(f"RUN  {where}: {text}{note}")
                    continue
                if text in done:
                    status, _, first = done[text]
                    counts[status] += 1
                    print(f"{status:4} {where}: {text}  (same as {first})")
                    continue
                earlier.insert(0, out)
                t0 = time.monotonic()
                try:
                    r = subprocess.run(argv, cwd=ROOT, env={**os.environ, **env},
                                       capture_output=True, text=True, timeout=TIMEOUT)
                    status = "OK" if r.returncode == 0 else "FAIL"
                    tail = (r.stderr.strip().splitlines() or [f"exit {r.returncode}"])[-3:]
                except subprocess.TimeoutExpired:
                    status, tail = "FAIL", [f"timed out after {TIMEOUT} s"]
                done[text] = (status, tail, where)
                counts[status] += 1
                print(f"{status:4} {where}: {text}  ({time.monotonic() - t0:.1f} s){note}",
                      flush=True)
                if status == "FAIL":
                    for t in tail:
                        print(f"       | {t}")
    finally:
        if not opts.keep:
            shutil.rmtree(tmp, ignore_errors=True)
    print(f"\n{counts['OK']} ok, {counts['FAIL']} failed, {counts['SKIP']} skipped "
          f"in {time.monotonic() - t_start:.0f} s" + (f"; outputs in {tmp}" if opts.keep else ""))
    return 1 if counts["FAIL"] else 0


if __name__ == "__main__":
    sys.exit(main())
