"""Every dependency the CMake files look for is on scripts/debian-packages.txt
(the list scripts/setup.sh installs), and the package on the list really
holds what CMake looks for. A package the build needs but setup.sh forgets
fails here, not on a new user's fresh machine.

Run by ctest (tests/CMakeLists.txt) as `python3 -m pytest tests/setup`.
"""

import os
import re
import shutil
import subprocess
from pathlib import Path

import pytest

ROOT = Path(os.environ.get("QUADHAND_SOURCE_DIR", Path(__file__).resolve().parents[2]))
PACKAGE_LIST = ROOT / "scripts" / "debian-packages.txt"
KINDS = ("find_package", "pkg_check_modules", "find_library", "find_path", "find_program")
# Packages this project makes itself (examples/cpp finds the installed QuadHand).
OURS = {("find_package", "quadhand")}
PKG_KEYWORDS = {"REQUIRED", "QUIET", "IMPORTED_TARGET", "GLOBAL", "NO_CMAKE_PATH", "NO_CMAKE_ENVIRONMENT_PATH"}


def read_package_list(path=None):
    """[(package, {(kind, name)}, condition or None)] in file order."""
    path = path or PACKAGE_LIST
    entries = []
    for number, line in enumerate(path.read_text().splitlines(), 1):
        line = line.split("#", 1)[0].split()
        if not line:
            continue
        package, provides, condition = line[0], set(), None
        for word in line[1:]:
            kind, sep, name = word.partition(":")
            assert sep and name, f"{path.name}:{number}: '{word}' is not KIND:NAME"
            if kind == "when-missing":
                condition = name
            else:
                assert kind in KINDS, f"{path.name}:{number}: unknown kind '{kind}'"
                provides.add((kind, name))
        entries.append((package, provides, condition))
    return entries


def cmake_files():
    try:  # a checkout: the files git knows (tracked, or new and not ignored)
        out = subprocess.run(["git", "-C", str(ROOT), "ls-files", "--cached", "--others", "--exclude-standard",
                              "*CMakeLists.txt", "*.cmake", "*.cmake.in"],
                             capture_output=True, text=True)
        if out.returncode == 0 and out.stdout.strip():
            return [ROOT / f for f in out.stdout.split()]
    except OSError:
        pass  # no git (a source archive, a fresh machine): walk the tree
    skip = {"build", "node_modules", ".git"}
    return [p for p in ROOT.rglob("*") if p.is_file() and not skip.intersection(p.relative_to(ROOT).parts)
            and (p.name == "CMakeLists.txt" or p.name.endswith((".cmake", ".cmake.in")))]


def strip_comments(text):
    return "\n".join(line.split("#", 1)[0] if not line.lstrip().startswith("#") else "" for line in text.splitlines())


def cmake_requests(text):
    """{(kind, name)} of what one CMake file looks for."""
    text = strip_comments(text)
    found = set()
    for match in re.finditer(r"\bfind_package\(\s*([A-Za-z0-9_.+-]+)", text):
        found.add(("find_package", match.group(1)))
    for match in re.finditer(r"\bpkg_check_modules\(\s*\w+([^)]*)\)", text):
        for word in match.group(1).split():
            word = word.strip("\"'")
            if word and word not in PKG_KEYWORDS:
                found.add(("pkg_check_modules", re.split(r"[<>=]", word)[0]))
    for kind in ("find_library", "find_path", "find_program"):
        for match in re.finditer(r"\b%s\(\s*\w+\s+(?:NAMES\s+)?([^\s)]+)" % kind, text):
            found.add((kind, match.group(1)))
    return found


def all_requests():
    requests = {}
    for path in cmake_files():
        for request in cmake_requests(path.read_text()):
            requests.setdefault(request, []).append(str(path.relative_to(ROOT)))
    return requests


def test_parser_sees_each_kind():
    text = """
    find_package(Foo 1.2 REQUIRED)  # find_package(Commented)
    # find_package(AlsoCommented)
    pkg_check_modules(BAR REQUIRED IMPORTED_TARGET bar>=2 baz)
    find_library(LIB_VAR NAMES qux)
    find_path(INC_VAR some/header.h PATH_SUFFIXES x)
    find_program(PROG_VAR node)
    """
    assert cmake_requests(text) == {("find_package", "Foo"), ("pkg_check_modules", "bar"),
                                    ("pkg_check_modules", "baz"), ("find_library", "qux"),
                                    ("find_path", "some/header.h"), ("find_program", "node")}


def test_setup_reads_the_same_list():
    setup = (ROOT / "scripts" / "setup.sh").read_text()
    assert "debian-packages.txt" in setup, "scripts/setup.sh must install from scripts/debian-packages.txt"


def test_every_cmake_request_is_on_the_list():
    provided = set().union(*(p for _, p, _ in read_package_list()))
    missing = {r: files for r, files in all_requests().items() if r not in provided and r not in OURS}
    assert not missing, "not on scripts/debian-packages.txt: " + "; ".join(
        f"{kind}({name}) in {', '.join(files)}" for (kind, name), files in sorted(missing.items()))


def test_every_listed_request_is_used():
    used = set(all_requests())
    stale = [(package, r) for package, provides, _ in read_package_list() for r in provides if r not in used]
    assert not stale, "listed but no CMake file asks for it: " + ", ".join(f"{p} {k}:{n}" for p, (k, n) in stale)


def dpkg_files(package):
    out = subprocess.run(["dpkg", "-L", package], capture_output=True, text=True)
    return out.stdout.splitlines() if out.returncode == 0 else None


def dpkg_depends(package):
    out = subprocess.run(["dpkg-query", "-W", "-f=${Depends}", package], capture_output=True, text=True)
    names = []
    for alternative in out.stdout.split(","):
        name = alternative.split("|")[0].strip().split(" ")[0].split(":")[0]
        if name:
            names.append(name)
    return names


def cmake_module_exists(name):
    cmake = shutil.which("cmake")
    if not cmake:
        return False
    share = Path(cmake).resolve().parents[1] / "share"
    return any(share.glob(f"cmake*/Modules/Find{name}.cmake"))


def holds(files, kind, name):
    lower = name.lower()
    if kind == "find_package":
        wanted = {f"{name}config.cmake".lower(), f"{lower}-config.cmake"}
        return any(Path(f).name.lower() in wanted for f in files)
    if kind == "pkg_check_modules":
        return any(Path(f).name == f"{name}.pc" for f in files)
    if kind == "find_library":
        return any(re.fullmatch(rf"lib{re.escape(name)}\.(so|a)", Path(f).name) for f in files)
    if kind == "find_path":
        return any(f.endswith("/" + name) for f in files)
    if kind == "find_program":
        return any(f in (f"/usr/bin/{name}", f"/bin/{name}") for f in files)
    return False


@pytest.mark.skipif(shutil.which("dpkg") is None, reason="not a Debian system: no dpkg to ask")
def test_each_package_holds_what_cmake_looks_for():
    problems = []
    for package, provides, condition in read_package_list():
        if condition and shutil.which(condition):
            continue  # installed only where `condition` is missing, e.g. Debian's npm beside NodeSource's node
        files = dpkg_files(package)
        if files is None:
            problems.append(f"{package} is not installed (run bash scripts/setup.sh)")
            continue
        for kind, name in sorted(provides):
            if holds(files, kind, name):
                continue
            # Debian often splits a -dev package: look one level of Depends down.
            if any(holds(dpkg_files(dep) or [], kind, name) for dep in dpkg_depends(package)):
                continue
            if kind == "find_package" and cmake_module_exists(name):
                continue  # CMake's own Find<Name> module finds it
            problems.append(f"{package} holds nothing for {kind}({name})")
    assert not problems, "; ".join(problems)
