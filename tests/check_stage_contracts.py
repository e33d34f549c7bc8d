#!/usr/bin/env python3
"""Checks the contract header of every pipeline stage (sql/stages/*.sql) against its SQL.

Each stage file starts with this header, the fields in this order, each on one line (a long list
continues on the next lines, `--` and spaces, no `name:`), `-` for an empty list, then `--`
alone and the stage's rationale:

    -- stage: align
    -- reads: points, calib_cameras, calibration, calibrated_values()
    -- makes: align_frames, align_origin, calib_match, calibration_summary, result_transforms()
    -- work: align_centroids, align_tracks, align_sample(), ...
    -- changes: points, calibration
    -- parameters: align_min_points, align_bin_s, ...
    --

  reads       every table or macro of the load (sql/pipeline.sql: points, load_*) or of an
              EARLIER stage (in sql/stages.sql order) that the stage's SQL names;
  makes       what the stage creates for later stages and the results (CREATE ... TABLE / VIEW /
              MACRO); work: what it creates only for itself (makes + work = every name it
              creates that no earlier stage made; no later stage reads a stage's work);
  changes     tables and macros of the load or an earlier stage that it replaces (CREATE OR
              REPLACE) or changes (INSERT INTO, UPDATE, DELETE FROM);
  parameters  what tunes the stage: every getvariable('name') of its SQL, and every value it reads
              through calibrated('name') or calibrated_values('name') (a parameter that may be
              `auto`, measured by calibrate.sql). Each parameter of crates/app/src/params.rs names
              its stage there: that stage's header must list it, and every listed parameter must
              be declared there.
Macros are written with `()`. Also: every repository path named in a comment or a doc (sql/...,
src/..., crates/..., tests/..., docs/..., scripts/..., python/..., benches/...) exists.
The check is exact (sets are compared both ways), and every
arrow points down: no stage names a table or macro made by a later stage, and no stage reads
one made by nobody before it.

What a statement creates or changes is read by the extension (trajdb_statement: the runner's own
reading, crates/app/src/plan.rs statement_action), over the statements the extension embeds
(trajdb_stages, trajdb_script): no second parser of statements here.

usage: python3 tests/check_stage_contracts.py path/to/trajdb.duckdb_extension [--print]
  (run from anywhere, with the `duckdb` module; exit 1 on a mismatch)
  --print  prints the contract each file's SQL implies (to write or update a header)
"""
import os
import re
import sys

ROOT = os.path.dirname(os.path.dirname(os.path.abspath(__file__)))
FIELDS = ("stage", "reads", "makes", "work", "changes", "parameters")

GETVAR = re.compile(r"getvariable\(\s*'([^']*)'\s*\)", re.I)
CALIBRATED = re.compile(r"\bcalibrated(?:_values)?\(\s*'([^']*)'\s*\)", re.I)
PARAM_DECL = re.compile(r'\b[dibs]\(\s*"(\w+)",\s*"(?:[^"\\]|\\.)*",\s*"(\w+)"')
# a repository path: a top-level folder of the repository, then a file or folder name
REPO_PATH = re.compile(r"(?<![\w./-])((?:\.ci|src|crates|sql|tests|docs|scripts|python|benches)/[\w./*-]*[\w*])")
PATH_SCAN = (".rs", ".sql", ".py", ".sh", ".md", ".toml", ".yml", ".slt")


def declared_params():
    """{name: stage} of every parameter in crates/app/src/params.rs."""
    text = open(os.path.join(ROOT, "crates/app/src/params.rs"), encoding="utf-8").read()
    return dict(PARAM_DECL.findall(text))


def missing_paths():
    """Every repository path named in a source file or a doc that does not exist. Placeholders
    (a name in capitals: sql/stages/NAME.sql), globs and templates (* < {) are not paths."""
    errors = []
    for top in ["README.md", ".ci", "src", "crates", "sql", "tests", "docs", "scripts", "python", "benches"]:
        start = os.path.join(ROOT, top)
        walk = [(ROOT, [], [top])] if os.path.isfile(start) else os.walk(start)
        for dirpath, dirs, files in walk:
            dirs[:] = [d for d in dirs if d not in ("target", "build", "__pycache__", "testdata", ".git")]
            for fname in sorted(files):
                if not (fname.endswith(PATH_SCAN) or dirpath.endswith(".ci")):
                    continue
                path = os.path.join(dirpath, fname)
                rel = os.path.relpath(path, ROOT)
                for no, line in enumerate(open(path, encoding="utf-8", errors="replace"), 1):
                    for m in REPO_PATH.finditer(line):
                        p = m.group(1).rstrip(".").split("#")[0]
                        if any(c in p for c in "*<{") or any(re.fullmatch(r"[A-Z][A-Z_]*(\.\w+)?", seg) for seg in p.split("/")):
                            continue
                        if not os.path.exists(os.path.join(ROOT, p)):
                            errors.append(f"{rel}:{no}: names {p}, which does not exist")
    return errors


def strip_comments(sql):
    """SQL without -- comments (string literals kept: getvariable('x') names live in them)."""
    out, i, n = [], 0, len(sql)
    while i < n:
        c = sql[i]
        if c == "'":
            j = i + 1
            while j < n:
                if sql[j] == "'" and j + 1 < n and sql[j + 1] == "'":
                    j += 2
                elif sql[j] == "'":
                    break
                else:
                    j += 1
            out.append(sql[i:j + 1])
            i = j + 1
        elif sql.startswith("--", i):
            j = sql.find("\n", i)
            i = n if j < 0 else j
        else:
            out.append(c)
            i += 1
    return "".join(out)


def strip_strings(code):
    """Code (comments already stripped) with every string literal emptied."""
    return re.sub(r"'(?:[^']|'')*'", "''", code)


def actions(con, query, args):
    """(action, name) of every statement of `query` (rows of trajdb_stages or trajdb_script) that
    creates or changes something, in order, as the runner reads it (trajdb_statement): action
    is table, view, macro, insert, delete or update. One query per file."""
    rows = con.execute(f"SELECT trajdb_statement(sql) FROM ({query}) ORDER BY k", args).fetchall()
    return [tuple(a.split(" ", 1)) for (a,) in rows if a]


def creates(acts):
    """(name, is_macro) of every CREATE, in order."""
    return [(n, a == "macro") for a, n in acts if a in ("table", "view", "macro")]


ANY_CREATE = re.compile(r"\bCREATE\s+(?:OR\s+REPLACE\s+)?(TEMP\s+|TEMPORARY\s+)?(\w+)\s+(?:IF\s+NOT\s+EXISTS\s+)?([\w.]+)", re.I)


def persistent_creates():
    """Every CREATE in every SQL file under sql/ (the stages, the load, analysis.sql, report.sql,
    ...) is TEMP: a run on your connection stores nothing in your database file (issue 37 §6;
    crates/app/src/plan.rs refuses such a manifest at run time too)."""
    errors = []
    for dirpath, _, files in os.walk(os.path.join(ROOT, "sql")):
        for f in sorted(files):
            if not f.endswith(".sql"):
                continue
            rel = os.path.relpath(os.path.join(dirpath, f), ROOT)
            bare = strip_strings(strip_comments(open(os.path.join(dirpath, f), encoding="utf-8").read()))
            for m in ANY_CREATE.finditer(bare):
                if not m.group(1):
                    errors.append(f"{rel}: CREATE {m.group(2)} {m.group(3)} is not TEMP: it would be stored in the user's database")
    return errors


def load_objects(con):
    """What the load step of sql/pipeline.sql creates (the manifest's stage 'load')."""
    return dict(creates(actions(con, "SELECT k, sql FROM trajdb_stages('x') WHERE stage = 'load'", [])))


def stage_files():
    """The stage files in run order. A stage file that `.read`s files (sql/stages/align.sql) is a
    stage of several files: each of them has its own header (`-- stage: align/coarse`) and is
    checked as a stage of its own, in the order read."""
    text = open(os.path.join(ROOT, "sql/stages.sql"), encoding="utf-8").read()
    out = []
    for rel in re.findall(r"^\.read\s+(sql/stages/\w+\.sql)\s*$", text, re.M):
        inner = re.findall(r"^\.read\s+(sql/stages/[\w/]+\.sql)\s*$", open(os.path.join(ROOT, rel), encoding="utf-8").read(), re.M)
        out += inner or [rel]
    return out


def parse_header(path, text):
    """The header's fields {field: [names]} (names as written, macros with `()`), or errors."""
    lines = text.split("\n")
    fields, errors, cur = {}, [], None
    for no, line in enumerate(lines, 1):
        if not line.startswith("--") or line.strip() == "--":
            break
        body = line[2:].strip()
        m = re.match(r"^(\w+):\s*(.*)$", body)
        if m and m.group(1) in FIELDS:
            cur = m.group(1)
            if cur in fields:
                errors.append(f"{path}:{no}: field {cur} given twice")
            fields[cur] = [m.group(2)]
        elif cur is not None and line.startswith("--  "):
            fields[cur].append(body)
        else:
            break
    if list(fields) != list(FIELDS):
        errors.append(f"{path}: the header must give {', '.join(FIELDS)} in this order (found: {', '.join(fields) or 'none'})")
    out = {}
    for k, parts in fields.items():
        joined = " ".join(parts).strip()
        if k == "stage":
            out[k] = joined
            continue
        names = [] if joined == "-" else [x.strip() for x in joined.split(",") if x.strip()]
        out[k] = names
    return out, errors


def references(code, name, is_macro):
    """Does `code` (comments and strings stripped) name the table or macro `name`? A column alias
    (AS name), a qualified column (x.name) and, for a table, a function call name( do not count."""
    for m in re.finditer(r"\b" + re.escape(name) + r"\b", code, re.I):
        before = code[:m.start()].rstrip()
        after = code[m.end():].lstrip()
        if before.endswith(".") or re.search(r"\bAS$", before, re.I):
            continue
        called = after.startswith("(")
        if called != is_macro:
            continue
        return True
    return False


def fmt(names, macros):
    return ", ".join(n + ("()" if macros.get(n) else "") for n in names) or "-"


def main():
    show = "--print" in sys.argv[1:]
    exts = [a for a in sys.argv[1:] if not a.startswith("--")]
    if len(exts) != 1:
        print(__doc__.split("usage:")[1].strip())
        return 2
    import duckdb

    con = duckdb.connect(config={"allow_unsigned_extensions": "true"})
    con.execute("LOAD " + "'" + os.path.abspath(exts[0]).replace("'", "''") + "'")
    errors = []
    made = dict(load_objects(con))
    embedded = con.execute("SELECT trajdb_pipeline_sql()").fetchall()[0][0]           # name -> is_macro, made so far (load + earlier stages)
    files = stage_files()
    # every name each stage creates, to find arrows pointing up
    later = {}
    infos = []
    listed = {}
    work_of = {}
    for rel in files:
        path = os.path.join(ROOT, rel)
        text = open(path, encoding="utf-8").read()
        code = strip_comments(text)
        bare = strip_strings(code)
        # the statements are the extension's embedded copy: it must be this file as it is on disk
        whole = "".join(line + "\n" for line in text.splitlines())
        if "\n" + whole + "\n;\n" not in embedded:
            print(f"check_stage_contracts: {rel} differs from the extension's embedded copy: rebuild it (scripts/build_extension.sh)")
            return 1
        acts = actions(con, "SELECT k, sql FROM trajdb_script(?)", [rel])
        infos.append((rel, text, code, bare, creates(acts), acts))
    for rel, _, _, _, cr, _ in infos:
        for n, mac in cr:
            later.setdefault(n, (rel, mac))
    for idx, (rel, text, code, bare, cr, acts) in enumerate(infos):
        stem = os.path.splitext(os.path.relpath(rel, "sql/stages"))[0]
        kinds = {}
        for n, mac in cr:
            kinds[n] = mac
        created = list(dict.fromkeys(n for n, _ in cr))
        new = [n for n in created if n not in made]
        changed = [n for n in created if n in made]
        for n in [n for a, n in acts if a in ("insert", "delete", "update")]:
            if n in made and n not in created and n not in changed:
                changed.append(n)
            elif n not in made and n not in created:
                errors.append(f"{rel}: changes {n}, which no earlier stage (nor the load) made and this stage does not create")
        # reads: earlier names named anywhere except as a statement's target
        targets = re.compile(r"\bCREATE\s+(?:OR\s+REPLACE\s+)?(?:TEMP\s+|TEMPORARY\s+)?(?:TABLE|VIEW|MACRO)\s+\w+|"
                             r"\b(?:INSERT\s+INTO|UPDATE|DELETE\s+FROM)\s+\w+", re.I)
        body = targets.sub(" ", bare)
        reads = [n for n in made if references(body, n, made[n])]
        # arrows up: a name made only by a LATER stage
        for n, (who, mac) in later.items():
            if n in made or n in created:
                continue
            if references(body, n, mac):
                errors.append(f"{rel}: names {n}{'()' if mac else ''}, made by the later stage {who}: every arrow must point down")
        params = sorted(set(GETVAR.findall(code)) | set(CALIBRATED.findall(code)))
        listed[stem] = params
        kinds_all = dict(made)
        kinds_all.update(kinds)
        if show:
            print(f"== {rel}")
            print(f"-- stage: {stem}")
            print(f"-- reads: {fmt(sorted(reads), kinds_all)}")
            print(f"-- makes/work: {fmt(new, kinds_all)}")
            print(f"-- changes: {fmt(sorted(changed), kinds_all)}")
            print(f"-- parameters: {', '.join(params) or '-'}")
        header, herr = parse_header(rel, text)
        errors += herr
        if not herr:
            if header["stage"] != stem:
                errors.append(f"{rel}: stage: {header['stage']!r}, but the file is {stem}")

            def check(field, declared, actual):
                # macros must be written with (), tables without
                for d in declared:
                    base = d[:-2] if d.endswith("()") else d
                    if base.lower() in kinds_all and kinds_all[base.lower()] != d.endswith("()"):
                        errors.append(f"{rel}: {field}: {d} should be written {fmt([base.lower()], kinds_all)}")
                dset = {(d[:-2] if d.endswith("()") else d).lower() for d in declared}
                aset = set(actual)
                for x in sorted(aset - dset):
                    errors.append(f"{rel}: {field}: missing {fmt([x], kinds_all)}")
                for x in sorted(dset - aset):
                    errors.append(f"{rel}: {field}: lists {x}, which the SQL does not {'name' if field == 'reads' else 'have'}")
                if len(dset) != len(declared):
                    errors.append(f"{rel}: {field}: a name is listed twice")

            # another stage's work is its own: what a later stage reads is made
            for n in reads:
                if n in work_of:
                    errors.append(f"{rel}: reads {n}, which {work_of[n]} lists as its own work: list it in that file's makes")
            for d in header["reads"]:
                base = (d[:-2] if d.endswith("()") else d).lower()
                if base not in made:
                    who = later.get(base, ("nobody", False))[0]
                    errors.append(f"{rel}: reads {d}, made by {who if base not in kinds else 'this stage'}, not by the load or an earlier stage")
            check("reads", header["reads"], reads)
            both = header["makes"] + header["work"]
            check("makes + work", both, new)
            check("changes", header["changes"], changed)
            check("parameters", header["parameters"], params)
        for n in new:
            made[n] = kinds[n]
        if not herr:
            for w in header["work"]:
                work_of[(w[:-2] if w.endswith("()") else w).lower()] = rel
    errors += persistent_creates()
    # params.rs names one stage per parameter: that stage tunes it (its header lists it)
    decl = declared_params()
    for name, stage in sorted(decl.items()):
        # a stage of several files (align) lists it in one of them (align/vote)
        files = [k for k in listed if k == stage or k.startswith(stage + "/")]
        if files and not any(name in listed[k] for k in files):
            who = [k for k, v in listed.items() if name in v]
            errors.append(f"crates/app/src/params.rs: {name} is declared for the stage {stage}, whose SQL does not read it "
                          f"(read by: {', '.join(who) or 'no stage'})")
    # the load's own variables (sql/pipeline.sql sets or reads them: input_t_type, load_camera_numbers)
    load_text = strip_comments(open(os.path.join(ROOT, "sql/pipeline.sql"), encoding="utf-8").read().split(".read sql/stages.sql")[0])
    load_vars = set(re.findall(r"\bSET\s+VARIABLE\s+(\w+)", load_text, re.I)) | set(GETVAR.findall(load_text))
    for stage, names in listed.items():
        for n in names:
            if n not in decl and n not in load_vars:
                errors.append(f"sql/stages/{stage}.sql: reads the parameter {n}, which crates/app/src/params.rs does not declare")
    errors += missing_paths()
    if errors:
        print("\n".join(errors))
        print(f"check_stage_contracts: {len(errors)} mismatch(es)")
        return 1
    print(f"check_stage_contracts: {len(infos)} stage headers match their SQL; every arrow points down")
    return 0


if __name__ == "__main__":
    sys.exit(main())
