#!/usr/bin/env python3
"""clang-tidy (.clang-tidy at the top) on every source file of ours in a build's
compile_commands.json, in parallel, with a cache: a file whose preprocessed text, compile flags
and .clang-tidy are unchanged since it last came out clean is not checked again (CI reruns are
cheap; any header change re-checks what includes it). Exit 1 when any file has a finding.
A unity build lists its batches (Unity/unity_N_cxx.cxx) instead of the sources: each batch is
checked as the sources it includes, each with the batch's flags (the database clang-tidy reads
is written to <build>/clang-tidy/compile_commands.json).

Usage: clang_tidy.py [--build-dir build/release] [--jobs N] [--no-cache] [--since REV] [paths...]
  paths: only files under these (default: every directory of ours but tests/fuzz)
  --since REV: only the files that changed since the git revision REV or include a header that
         did (from the build's ninja dependency records; every file when .clang-tidy, the top
         CMakeLists.txt, CMakePresets.json or cmake/ changed, or REV is unknown). CI passes the
         commit recorded in .ci/tidy-baseline, where the whole tree was last checked clean, so a
         cold CI machine does not re-check every file (about 26 minutes on 2 cores).
"""
import argparse
import concurrent.futures
import hashlib
import json
import os
import pathlib
import re
import shlex
import subprocess
import sys
import time

ROOT = pathlib.Path(__file__).resolve().parent.parent
DEFAULT_DIRS = ("common", "storage", "core", "server", "client", "tools", "bench", "tests")
CACHE_DIR = pathlib.Path(os.environ.get("SEMMAP_TIDY_CACHE",
                                        pathlib.Path.home() / ".cache" / "semmap-clang-tidy"))


def find_clang_tidy() -> str:
    for name in ("clang-tidy", "clang-tidy-14"):
        try:
            subprocess.run([name, "--version"], capture_output=True, check=True)
            return name
        except (OSError, subprocess.CalledProcessError):
            continue
    sys.exit("clang_tidy: clang-tidy not found (bash scripts/install-deps.sh lint)")


def compile_args(entry: dict) -> list:
    """A compile_commands.json entry's command line as a list."""
    return shlex.split(entry["command"]) if "command" in entry else list(entry["arguments"])


UNITY_INCLUDE = re.compile(r'^#include "(.+)"$', re.MULTILINE)


def expand_unity(entries: list) -> list:
    """One entry per source of each unity batch: the batch's command with the source in its place
    and the batch's object as output (its ninja records name every header of the batch)."""
    expanded = []
    for entry in entries:
        batch = pathlib.Path(entry["directory"], entry["file"])
        if batch.parent.name != "Unity" or not batch.name.startswith("unity_"):
            expanded.append(entry)
            continue
        args = compile_args(entry)
        output = entry.get("output") or object_of(entry)
        for source in UNITY_INCLUDE.findall(batch.read_text()):
            expanded.append({"directory": entry["directory"], "file": source, "output": output,
                             "arguments": [source if a == entry["file"] else a for a in args]})
    return expanded


def cache_key(entry: dict, config: bytes) -> str:
    """sha256 of the preprocessed file (every header it includes), its flags and the config."""
    args = compile_args(entry)
    # Drop the output so the same file preprocesses the same in any build directory.
    cleaned = []
    skip = False
    for arg in args:
        if skip:
            skip = False
            continue
        if arg in ("-o", "-MF", "-MT", "-MQ"):
            skip = True
            continue
        if arg in ("-MD", "-MMD") or arg.startswith("-o"):
            continue
        cleaned.append(arg)
    pre = subprocess.run(cleaned + ["-E", "-P", "-o", "-"], cwd=entry["directory"],
                         capture_output=True, check=False)
    digest = hashlib.sha256()
    digest.update(config)
    digest.update(pre.stdout if pre.returncode == 0 else os.urandom(16))
    digest.update(" ".join(a for a in cleaned if a.startswith(("-D", "-std", "-f"))).encode())
    return digest.hexdigest()


def check(tidy: str, database_dir: str, entry: dict, config: bytes, use_cache: bool):
    path = entry["file"]
    key = cache_key(entry, config) if use_cache else None
    if key and (CACHE_DIR / key).exists():
        return path, "", True
    # The build's flags are gcc's (-Wshadow=local, -Wno-error=restrict under -Werror): clang
    # must not turn the options it does not know into findings.
    result = subprocess.run([tidy, "-p", database_dir, "--quiet",
                             "--extra-arg=-Wno-unknown-warning-option", path],
                            capture_output=True, text=True, check=False)
    findings = "\n".join(line for line in result.stdout.splitlines()
                         if ": warning:" in line or ": error:" in line or line.startswith(" "))
    clean = result.returncode == 0 and ": warning:" not in result.stdout
    if clean and key:
        CACHE_DIR.mkdir(parents=True, exist_ok=True)
        (CACHE_DIR / key).touch()
    return path, (result.stdout if not clean else ""), False


def changed_since(rev: str):
    """Absolute paths of the files that differ between REV and the work tree (committed or not),
    or None when REV is unknown."""
    diff = subprocess.run(["git", "diff", "--name-only", rev, "--"], cwd=ROOT, capture_output=True,
                          text=True, check=False)
    if diff.returncode != 0:
        return None
    names = diff.stdout.split()
    untracked = subprocess.run(["git", "ls-files", "--others", "--exclude-standard"], cwd=ROOT,
                               capture_output=True, text=True, check=True).stdout.split()
    return {str((ROOT / n).resolve()) for n in names + untracked}


def object_of(entry: dict) -> str:
    args = compile_args(entry)
    return args[args.index("-o") + 1] if "-o" in args[:-1] else ""


def affected(entries: list, build_dir: str, changed: set) -> list:
    """The entries whose source or any header it includes (ninja's records) is in `changed`."""
    # The project-wide configuration (tidy checks, compile options) re-checks everything; a
    # module's CMakeLists.txt only adds or links targets, whose new files are in `changed`.
    global_config = {str((ROOT / name).resolve())
                     for name in (".clang-tidy", "CMakeLists.txt", "CMakePresets.json")}
    if changed & global_config or any(
            name.startswith(str((ROOT / "cmake").resolve()) + os.sep) for name in changed):
        return entries
    deps = subprocess.run(["ninja", "-C", build_dir, "-t", "deps"], capture_output=True, text=True,
                          check=False)
    if deps.returncode != 0:
        print("clang_tidy: no ninja dependency records; checking every file", file=sys.stderr)
        return entries
    headers_of, target = {}, None
    for line in deps.stdout.splitlines():
        if line and not line[0].isspace():
            target = line.split(":", 1)[0]
            headers_of[target] = set()
        elif line.strip() and target is not None:
            dep = line.strip()
            if not dep.endswith((".cc", ".cxx")):  # a unity batch's other sources are not headers
                headers_of[target].add(str((pathlib.Path(build_dir) / dep).resolve()))
    selected = []
    for entry in entries:
        source = str(pathlib.Path(entry["file"]).resolve())
        output = entry.get("output") or object_of(entry)
        if source in changed or headers_of.get(output, set()) & changed or output not in headers_of:
            selected.append(entry)
    return selected


def main() -> int:
    parser = argparse.ArgumentParser()
    parser.add_argument("--build-dir", default=str(ROOT / "build" / "release"))
    parser.add_argument("--jobs", type=int, default=os.cpu_count() or 2)
    parser.add_argument("--no-cache", action="store_true")
    parser.add_argument("--since", help="only files affected by changes since this git revision")
    parser.add_argument("paths", nargs="*")
    args = parser.parse_args()
    database = pathlib.Path(args.build_dir) / "compile_commands.json"
    if not database.exists():
        sys.exit(f"clang_tidy: {database} is missing (configure the build first)")
    prefixes = [str((ROOT / p).resolve()) for p in (args.paths or DEFAULT_DIRS)]
    # Unity batches as their sources: what is checked, and the database clang-tidy reads.
    all_entries = expand_unity(json.loads(database.read_text()))
    database_dir = pathlib.Path(args.build_dir) / "clang-tidy"
    database_dir.mkdir(exist_ok=True)
    (database_dir / "compile_commands.json").write_text(json.dumps(all_entries, indent=1))
    entries = [e for e in all_entries
               if any(str(pathlib.Path(e["file"]).resolve()).startswith(p + os.sep) or
                      str(pathlib.Path(e["file"]).resolve()) == p for p in prefixes)
               and "/tests/fuzz/" not in e["file"]]
    if args.since:
        total = len(entries)
        changed = changed_since(args.since)
        if changed is None:
            print(f"clang_tidy: {args.since} is not a revision here (shallow clone?); checking "
                  "every file", file=sys.stderr)
        else:
            entries = affected(entries, args.build_dir, changed)
        print(f"clang_tidy: {len(entries)} of {total} files affected by changes since "
              f"{args.since}", file=sys.stderr)
    config = (ROOT / ".clang-tidy").read_bytes()
    tidy = find_clang_tidy()
    start = time.monotonic()
    failed, cached, done = [], 0, 0
    with concurrent.futures.ThreadPoolExecutor(max_workers=args.jobs) as pool:
        futures = [pool.submit(check, tidy, str(database_dir), e, config, not args.no_cache)
                   for e in entries]
        for future in concurrent.futures.as_completed(futures):
            path, output, was_cached = future.result()
            done += 1
            cached += was_cached
            if output:
                failed.append(path)
                print(output, flush=True)
            if done % 25 == 0 or done == len(entries):
                print(f"clang_tidy: {done}/{len(entries)} files ({cached} unchanged and clean), "
                      f"{time.monotonic() - start:.0f} s", file=sys.stderr, flush=True)
    if failed:
        print(f"clang_tidy: findings in {len(failed)} of {len(entries)} files", file=sys.stderr)
        return 1
    print(f"clang_tidy: {len(entries)} files clean ({cached} from the cache)")
    return 0


if __name__ == "__main__":
    sys.exit(main())
