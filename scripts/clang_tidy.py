#!/usr/bin/env python3
"""clang-tidy (.clang-tidy at the top) on every source file of ours in a build's
compile_commands.json, in parallel, with a cache: a file whose preprocessed text, compile flags
and .clang-tidy are unchanged since it last came out clean is not checked again (CI reruns are
cheap; any header change re-checks what includes it). Exit 1 when any file has a finding.

Usage: clang_tidy.py [--build-dir build/release] [--jobs N] [--no-cache] [paths...]
  paths: only files under these (default: common storage core server client tools bench;
         tests/ is not clean yet: 59 findings, mostly performance checks on test fixtures)
"""
import argparse
import concurrent.futures
import hashlib
import json
import os
import pathlib
import shlex
import subprocess
import sys
import time

ROOT = pathlib.Path(__file__).resolve().parent.parent
DEFAULT_DIRS = ("common", "storage", "core", "server", "client", "tools", "bench")
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


def cache_key(entry: dict, config: bytes) -> str:
    """sha256 of the preprocessed file (every header it includes), its flags and the config."""
    args = shlex.split(entry["command"]) if "command" in entry else list(entry["arguments"])
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


def check(tidy: str, build_dir: str, entry: dict, config: bytes, use_cache: bool):
    path = entry["file"]
    key = cache_key(entry, config) if use_cache else None
    if key and (CACHE_DIR / key).exists():
        return path, "", True
    result = subprocess.run([tidy, "-p", build_dir, "--quiet", path], capture_output=True,
                            text=True, check=False)
    findings = "\n".join(line for line in result.stdout.splitlines()
                         if ": warning:" in line or ": error:" in line or line.startswith(" "))
    clean = result.returncode == 0 and ": warning:" not in result.stdout
    if clean and key:
        CACHE_DIR.mkdir(parents=True, exist_ok=True)
        (CACHE_DIR / key).touch()
    return path, (result.stdout if not clean else ""), False


def main() -> int:
    parser = argparse.ArgumentParser()
    parser.add_argument("--build-dir", default=str(ROOT / "build" / "release"))
    parser.add_argument("--jobs", type=int, default=os.cpu_count() or 2)
    parser.add_argument("--no-cache", action="store_true")
    parser.add_argument("paths", nargs="*")
    args = parser.parse_args()
    database = pathlib.Path(args.build_dir) / "compile_commands.json"
    if not database.exists():
        sys.exit(f"clang_tidy: {database} is missing (configure the build first)")
    prefixes = [str((ROOT / p).resolve()) for p in (args.paths or DEFAULT_DIRS)]
    entries = [e for e in json.loads(database.read_text())
               if any(str(pathlib.Path(e["file"]).resolve()).startswith(p + os.sep) or
                      str(pathlib.Path(e["file"]).resolve()) == p for p in prefixes)
               and "/tests/fuzz/" not in e["file"]]
    config = (ROOT / ".clang-tidy").read_bytes()
    tidy = find_clang_tidy()
    start = time.monotonic()
    failed, cached, done = [], 0, 0
    with concurrent.futures.ThreadPoolExecutor(max_workers=args.jobs) as pool:
        futures = [pool.submit(check, tidy, args.build_dir, e, config, not args.no_cache)
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
