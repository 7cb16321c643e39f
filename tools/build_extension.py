#!/usr/bin/env python3
# SPDX-License-Identifier: GPL-3.0-or-later
"""Build and validate installable Flank Toolpath extension zips.

Steps
-----
1. Download UNMODIFIED scipy wheels from PyPI (``pip download --only-binary=:all:
   --no-deps --platform ... --python-version ... --implementation cp``) into the
   git-ignored ``wheels/`` folder, once; later runs reuse them.  Two CPython ABIs:
   cp311 (Blender 4.2 - 5.0, numpy 1.26) and cp313 (Blender 5.1+, numpy 2.x).
   numpy itself is never bundled (Blender ships it).
2. Keep the ``wheels = [...]`` list of ``blender_manifest.toml`` in sync (rewritten
   when all platforms are built) and stage a copy of the source tree whose
   manifest lists only the requested platforms / wheels.
3. Build with Blender's own extension CLI (``blender_ext.py`` shipped inside the
   ``bpy`` wheel, or ``blender --command extension build`` if no bpy is importable)
   using ``--split-platforms`` -> ``dist/flank_toolpath-<version>-<platform>.zip``.
4. Validate each zip with the same CLI (``validate``) plus a content check.

Usage::

    python tools/build_extension.py                      # all platforms -> dist/
    python tools/build_extension.py --platforms linux-x64
    python tools/build_extension.py --platforms host --output-dir /tmp/x --json /tmp/x/build.json

Environment: ``PLATFORMS`` (same as --platforms), ``BLENDER_EXT_CLI`` (path to a
``blender_ext.py``), ``BLENDER`` (path to a blender binary).
"""
import argparse
import hashlib
import json
import os
import platform as _platform
import re
import shutil
import subprocess
import sys
import tempfile
import time
import zipfile
from pathlib import Path

ROOT = Path(__file__).resolve().parents[1]
MANIFEST = ROOT / "blender_manifest.toml"
WHEEL_DIR = ROOT / "wheels"

# scipy 1.17.1: wheels for cp311 + cp313 on all four platforms, built against
# numpy 2 (ABI-compatible with numpy 1.26.4 of Blender 4.2-5.0 and numpy 2.x of
# Blender 5.1+), declares numpy>=1.26.4,<2.7.
SCIPY_VERSION = "1.17.1"
PYTHON_VERSIONS = ("3.11", "3.13")

# Blender platform -> (pip --platform tag, matcher for cached wheel platform tags)
# The pip tag is the newest acceptable one; pip also accepts older compatible tags.
PLATFORMS = {
    # Blender 4.2+ on Linux needs glibc 2.28
    "linux-x64": "manylinux_2_28_x86_64",
    "windows-x64": "win_amd64",
    # OpenBLAS builds (the macosx_14_0 Accelerate builds would need macOS 14)
    "macos-arm64": "macosx_12_0_arm64",
    "macos-x64": "macosx_10_14_x86_64",
}

# Top-level entries never copied into the staging tree (the manifest's
# paths_exclude_pattern filters everything else, exactly as in a source build).
STAGE_SKIP = {".git", "wheels", "dist", "build", "out", ".pytest_cache", "__pycache__"}
# Paths that must be in / must not be in an add-on zip.
REQUIRED_IN_ZIP = ("blender_manifest.toml", "__init__.py", "operators/__init__.py", "panels/__init__.py",
                   "flank_addon/__init__.py")
FORBIDDEN_PREFIXES = ("tests/", "bench/", "tools/", "docs/", ".venv", "dist/", "out/", ".ci/", ".git", "Makefile",
                      "pyproject.toml", "build/")


class BuildError(RuntimeError):
    pass


def log(msg):
    print("[build_extension] " + msg, flush=True)


# --------------------------------------------------------------------------- platforms & wheels

def host_platform():
    system = {"darwin": "macos", "linux": "linux", "windows": "windows"}.get(_platform.system().lower(), "?")
    machine = _platform.machine().lower()
    machine = {"x86_64": "x64", "amd64": "x64", "aarch64": "arm64", "arm64": "arm64"}.get(machine, machine)
    return "{}-{}".format(system, machine)


def parse_platforms(value):
    value = (value or "all").strip()
    if value == "all":
        return list(PLATFORMS)
    out = []
    for item in re.split(r"[,\s]+", value):
        if not item:
            continue
        item = host_platform() if item == "host" else item
        if item not in PLATFORMS:
            raise BuildError("unknown platform {!r} (choose from {}, 'host' or 'all')".format(
                item, ", ".join(PLATFORMS)))
        if item not in out:
            out.append(item)
    if not out:
        raise BuildError("no platforms selected")
    return out


def _wheel_fields(name):
    """(python_tag, abi_tag, [platform tags]) of a wheel file name."""
    stem = name[:-len(".whl")]
    parts = stem.split("-")
    if len(parts) < 5:
        return None
    return parts[-3], parts[-2], parts[-1].split(".")


def _tag_fits(blender_platform, tag):
    target = PLATFORMS[blender_platform]
    if blender_platform == "windows-x64":
        return tag == "win_amd64"
    if blender_platform == "linux-x64":
        if tag in ("manylinux1_x86_64", "manylinux2010_x86_64", "manylinux2014_x86_64"):
            return True
        m = re.fullmatch(r"manylinux_(\d+)_(\d+)_x86_64", tag)
        return bool(m) and (int(m[1]), int(m[2])) <= (2, 28)
    m_t = re.fullmatch(r"macosx_(\d+)_(\d+)_(\w+)", target)
    m = re.fullmatch(r"macosx_(\d+)_(\d+)_(\w+)", tag)
    if not m:
        return False
    arch_ok = m[3] == m_t[3] or m[3] == "universal2"
    return arch_ok and (int(m[1]), int(m[2])) <= (int(m_t[1]), int(m_t[2]))


def find_cached_wheel(blender_platform, pyver):
    cp = "cp" + pyver.replace(".", "")
    if not WHEEL_DIR.is_dir():
        return None
    hits = []
    for path in sorted(WHEEL_DIR.glob("scipy-{}-*.whl".format(SCIPY_VERSION))):
        fields = _wheel_fields(path.name)
        if fields and fields[0] == cp and fields[1] == cp and any(_tag_fits(blender_platform, t) for t in fields[2]):
            hits.append(path)
    return hits[-1] if hits else None


def download_wheel(blender_platform, pyver):
    WHEEL_DIR.mkdir(exist_ok=True)
    cp = "cp" + pyver.replace(".", "")
    cmd = [sys.executable, "-m", "pip", "download", "--disable-pip-version-check", "--quiet",
           "--only-binary=:all:", "--no-deps", "--platform", PLATFORMS[blender_platform],
           "--python-version", pyver, "--implementation", "cp", "--abi", cp,
           "--dest", str(WHEEL_DIR), "scipy=={}".format(SCIPY_VERSION)]
    log("downloading scipy {} {} {}".format(SCIPY_VERSION, cp, blender_platform))
    proc = subprocess.run(cmd, stdout=subprocess.PIPE, stderr=subprocess.STDOUT, text=True)
    if proc.returncode != 0:
        raise BuildError("pip download failed for {} {}:\n{}".format(cp, blender_platform, proc.stdout))
    path = find_cached_wheel(blender_platform, pyver)
    if path is None:
        raise BuildError("pip download gave no usable wheel for {} {}:\n{}".format(cp, blender_platform, proc.stdout))
    with zipfile.ZipFile(path) as zf:
        bad = zf.testzip()
    if bad is not None:
        path.unlink()
        raise BuildError("corrupt download {} (member {})".format(path.name, bad))
    return path


def ensure_wheels(platforms, offline=False):
    """{(platform, pyver): Path} for the requested platforms, downloading what is missing."""
    out = {}
    for plat in platforms:
        for pyver in PYTHON_VERSIONS:
            path = find_cached_wheel(plat, pyver)
            if path is None:
                if offline:
                    raise BuildError("missing wheel for {} cp{} in {} (offline)".format(
                        plat, pyver.replace(".", ""), WHEEL_DIR))
                path = download_wheel(plat, pyver)
            out[(plat, pyver)] = path
    return out


# --------------------------------------------------------------------------- manifest

_WHEELS_RE = re.compile(r"^wheels\s*=\s*\[.*?\]\s*$", re.S | re.M)
_PLATFORMS_RE = re.compile(r"^platforms\s*=\s*\[.*?\]\s*$", re.S | re.M)


def _toml_list(key, items):
    if not items:
        return "{} = []".format(key)
    return "{} = [\n{}\n]".format(key, "\n".join('  "{}",'.format(i) for i in items))


def manifest_with(text, platforms, wheel_names):
    for regex, block in ((_PLATFORMS_RE, _toml_list("platforms", platforms)),
                         (_WHEELS_RE, _toml_list("wheels", ["./wheels/" + n for n in wheel_names]))):
        if regex.search(text):
            text = regex.sub(lambda _m, b=block: b, text, count=1)
        else:
            # insert before the first table header so the key stays top-level
            idx = text.find("\n[")
            idx = len(text) if idx < 0 else idx + 1
            text = text[:idx] + block + "\n\n" + text[idx:]
    return text


def read_manifest():
    import tomllib

    text = MANIFEST.read_text(encoding="utf-8")
    return text, tomllib.loads(text)


def sync_root_manifest(wheels_by_key, all_platforms_built):
    """Keep the committed manifest's wheel list equal to the full platform x ABI set."""
    text, data = read_manifest()
    listed = [Path(w).name for w in data.get("wheels", [])]
    chosen = [p.name for p in wheels_by_key.values()]
    if all_platforms_built:
        ordered = [wheels_by_key[(plat, py)].name for plat in PLATFORMS for py in PYTHON_VERSIONS]
        if listed != ordered or data.get("platforms") != list(PLATFORMS):
            MANIFEST.write_text(manifest_with(text, list(PLATFORMS), ordered), encoding="utf-8")
            log("updated wheel list in {}".format(MANIFEST.name))
    else:
        missing = [n for n in chosen if n not in listed]
        if missing:
            log("WARNING: blender_manifest.toml does not list {} -- run a full build "
                "(make extension) to refresh it".format(", ".join(missing)))


# --------------------------------------------------------------------------- Blender CLI

def find_blender_cli():
    """Command prefix running Blender's extension CLI: [python, blender_ext.py] or [blender, --command, extension]."""
    env_cli = os.environ.get("BLENDER_EXT_CLI")
    if env_cli:
        return [sys.executable, env_cli], env_cli
    import importlib.util

    spec = importlib.util.find_spec("bpy")
    if spec is not None and spec.origin:
        base = Path(spec.origin).parent
        hits = sorted(base.glob("*/scripts/addons_core/bl_pkg/cli/blender_ext.py"))
        if hits:
            return [sys.executable, str(hits[-1])], str(hits[-1])
    blender = os.environ.get("BLENDER") or shutil.which("blender")
    if blender:
        return [blender, "--background", "--factory-startup", "--command", "extension"], blender
    raise BuildError("Blender's extension CLI not found: install bpy (make venv), put `blender` on PATH, "
                     "or set BLENDER_EXT_CLI=/path/to/blender_ext.py")


def run_cli(prefix, args):
    proc = subprocess.run(prefix + args, stdout=subprocess.PIPE, stderr=subprocess.STDOUT, text=True)
    return proc.returncode, proc.stdout


# --------------------------------------------------------------------------- staging, build, validate

def _link_or_copy(src, dst):
    try:
        os.link(src, dst)
    except OSError:
        shutil.copy2(src, dst)


def stage_tree(stage, platforms, wheel_paths):
    ignore = shutil.ignore_patterns("__pycache__", "*.pyc", ".pytest_cache")
    for entry in ROOT.iterdir():
        if entry.name in STAGE_SKIP or entry.name.startswith(".venv") or entry.name.endswith(".zip"):
            continue
        if entry.is_dir():
            shutil.copytree(entry, stage / entry.name, ignore=ignore, symlinks=False)
        elif entry.is_file():
            shutil.copy2(entry, stage / entry.name)
    (stage / "wheels").mkdir()
    for path in wheel_paths:
        _link_or_copy(path, stage / "wheels" / path.name)
    text, _ = read_manifest()
    (stage / "blender_manifest.toml").write_text(
        manifest_with(text, platforms, [p.name for p in wheel_paths]), encoding="utf-8")


def check_zip(zip_path, expected_wheels):
    with zipfile.ZipFile(zip_path) as zf:
        names = zf.namelist()
        bad = zf.testzip()
    if bad is not None:
        raise BuildError("{}: corrupt member {}".format(zip_path.name, bad))
    problems = ["missing " + n for n in REQUIRED_IN_ZIP if n not in names]
    problems += ["missing wheel " + w for w in expected_wheels if "wheels/" + w not in names]
    problems += ["unexpected " + n for n in names if n.startswith(FORBIDDEN_PREFIXES)]
    problems += ["unexpected " + n for n in names if "__pycache__" in n or n.endswith(".pyc")]
    if problems:
        raise BuildError("{}: {}".format(zip_path.name, "; ".join(problems[:20])))
    return len(names)


def build(platforms, output_dir, offline=False, verbose=False):
    t0 = time.perf_counter()
    _, data = read_manifest()
    ext_id, version = data["id"], data["version"]
    wheels = ensure_wheels(platforms, offline=offline)
    t_wheels = time.perf_counter() - t0
    sync_root_manifest(wheels, all_platforms_built=set(platforms) == set(PLATFORMS))

    prefix, cli_where = find_blender_cli()
    output_dir = Path(output_dir).resolve()
    output_dir.mkdir(parents=True, exist_ok=True)
    results = []
    (ROOT / "build").mkdir(exist_ok=True)
    with tempfile.TemporaryDirectory(prefix="stage-", dir=ROOT / "build") as tmp:
        stage = Path(tmp) / ext_id
        stage.mkdir()
        stage_tree(stage, platforms, [wheels[(p, v)] for p in platforms for v in PYTHON_VERSIONS])
        # stale zips of the same platforms would be confusing: the CLI overwrites, but remove first anyway
        for plat in platforms:
            stale = output_dir / "{}-{}-{}.zip".format(ext_id, version, plat.replace("-", "_"))
            if stale.exists():
                stale.unlink()
        args = ["build", "--source-dir", str(stage), "--output-dir", str(output_dir), "--split-platforms"]
        if verbose:
            args.append("--verbose")
        t1 = time.perf_counter()
        rc, out = run_cli(prefix, args)
        if verbose or rc != 0:
            print(out)
        if rc != 0:
            raise BuildError("extension build failed (exit {}) using {}".format(rc, cli_where))
        t_build = time.perf_counter() - t1

    for plat in platforms:
        zip_path = output_dir / "{}-{}-{}.zip".format(ext_id, version, plat.replace("-", "_"))
        if not zip_path.is_file():
            raise BuildError("expected {} was not produced; CLI output:\n{}".format(zip_path, out))
        rc, vout = run_cli(prefix, ["validate", str(zip_path)])
        if rc != 0 or "error" in vout.lower():
            raise BuildError("validation failed for {}:\n{}".format(zip_path.name, vout))
        expected = [wheels[(plat, v)].name for v in PYTHON_VERSIONS]
        n_files = check_zip(zip_path, expected)
        size = zip_path.stat().st_size
        results.append(dict(platform=plat, path=str(zip_path), size=size, files=n_files, wheels=expected,
                            sha256=hashlib.sha256(zip_path.read_bytes()).hexdigest()))
        log("{}  {:.1f} MB  ({} files, validated)".format(zip_path.relative_to(output_dir.parent)
                                                         if output_dir.parent in zip_path.parents else zip_path,
                                                         size / 1e6, n_files))
    summary = dict(id=ext_id, version=version, scipy=SCIPY_VERSION, python=list(PYTHON_VERSIONS),
                   cli=cli_where, zips=results,
                   timings=dict(wheels_s=round(t_wheels, 3), build_s=round(t_build, 3),
                                total_s=round(time.perf_counter() - t0, 3)))
    return summary


def main(argv=None):
    ap = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    ap.add_argument("--platforms", default=os.environ.get("PLATFORMS", "all"),
                    help="'all' (default), 'host', or a comma list of {}".format(", ".join(PLATFORMS)))
    ap.add_argument("--output-dir", default=str(ROOT / "dist"), help="where the zips go (default dist/)")
    ap.add_argument("--offline", action="store_true", help="never download; fail if a wheel is missing")
    ap.add_argument("--download-only", action="store_true", help="only fetch the wheels into wheels/")
    ap.add_argument("--json", metavar="PATH", help="also write the build summary as JSON")
    ap.add_argument("--verbose", action="store_true")
    args = ap.parse_args(argv)
    try:
        platforms = parse_platforms(args.platforms)
        if args.download_only:
            for key, path in ensure_wheels(platforms, offline=args.offline).items():
                log("{} cp{}: {}".format(key[0], key[1].replace(".", ""), path.name))
            return 0
        summary = build(platforms, args.output_dir, offline=args.offline, verbose=args.verbose)
    except BuildError as ex:
        print("[build_extension] ERROR: {}".format(ex), file=sys.stderr)
        return 1
    if args.json:
        Path(args.json).parent.mkdir(parents=True, exist_ok=True)
        Path(args.json).write_text(json.dumps(summary, indent=2), encoding="utf-8")
    log("done in {:.1f}s ({} zip(s))".format(summary["timings"]["total_s"], len(summary["zips"])))
    return 0


if __name__ == "__main__":
    sys.exit(main())
