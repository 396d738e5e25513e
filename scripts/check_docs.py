#!/usr/bin/env python3
"""Checks the documentation against the tree and the built tools.

  - every relative link of README.md, docs/, deploy/ and client/python/ names a file or
    folder that exists, and a #fragment names a heading of that page;
  - every command-line flag the pages show exists: a flag after one of our commands (in a
    code block or an inline code span) in that command's --help (for `sceneloc SUB`, in
    SUB's), a flag after one of our scripts in that script's text, any other flag in some
    tool's --help;
  - every setting written as `section.key` exists in the documented configs (configs/).

Usage: scripts/check_docs.py BUILD_DIR   (run by ctest as docs/DocsMatchTheTree)
Prints each problem as FILE:LINE: what; exits 1 if there is any.
"""
import os
import re
import subprocess
import sys

ROOT = os.path.dirname(os.path.dirname(os.path.abspath(__file__)))
PAGES = ["README.md", "deploy/README.md", "client/python/README.md"] + sorted(
    "docs/" + name for name in os.listdir(os.path.join(ROOT, "docs")) if name.endswith(".md"))
TOOLS = {
    "sceneloc-train": "tools", "sceneloc-eval": "tools", "sceneloc-accuracy": "tools",
    "sceneloc-experiments": "tools", "sceneloc-gentour": "tools",
    "sceneloc-server": "server", "sceneloc-broker": "server", "sceneloc": "client",
}
# Commands of other programs whose flags are theirs, not ours.
FOREIGN = {"docker", "curl", "cmake", "ctest", "pip", "pip3", "git", "kill", "apt-get", "apt",
           "systemctl", "python3", "pytest", "buildah", "kubectl", "sort", "ls", "grep", "ssh",
           "sudo", "dpkg", "journalctl", "clang-format", "make", "tar", "cp", "mv", "rm", "echo"}
FLAG = re.compile(r"(?<![\w/.-])--[a-z][a-z0-9-]*")
LINK = re.compile(r"\[[^\]]*\]\(([^)\s]+)\)")
SETTING = re.compile(r"`([a-z_]+)\.([a-z_0-9]+)`")
FILE_KINDS = {"yaml", "cc", "h", "md", "py", "sh", "json", "csv", "png", "proto", "txt"}


def help_text(binary, *args):
    try:
        out = subprocess.run([binary, *args, "--help"], capture_output=True, text=True,
                             timeout=30)
    except OSError as e:
        sys.exit(f"check_docs: cannot run {binary}: {e}")
    return out.stdout + out.stderr


def flags_of(text):
    return set(FLAG.findall(text))


def slug(heading):
    s = heading.strip().lower()
    s = re.sub(r"[^\w\- ]", "", s)
    return s.replace(" ", "-")


def headings(path):
    found, fence = set(), False
    with open(path, encoding="utf-8") as f:
        for line in f:
            if line.startswith("```"):
                fence = not fence
            elif not fence and line.startswith("#"):
                found.add(slug(line.lstrip("#")))
    return found


def settings_keys():
    keys = set()
    for name in os.listdir(os.path.join(ROOT, "configs")):
        if not name.endswith(".yaml"):
            continue
        section = None
        with open(os.path.join(ROOT, "configs", name), encoding="utf-8") as f:
            for line in f:
                top = re.match(r"^([a-z_]+):", line)
                if top:
                    section = top.group(1)
                    keys.add(("", section))
                    continue
                inner = re.match(r"^  ([a-z_0-9]+):", line)
                if inner and section:
                    keys.add((section, inner.group(1)))
    return keys


def command_contexts(text):
    """(command, subcommand, flag) for each flag in a line or code span: the command is the
    one that starts the flag's pipeline segment or, within it, the nearest of ours or a
    script before the flag (None if none). A segment that starts with another program's
    command is not ours and gives nothing."""
    out = []
    for segment in re.split(r"\|\||&&|[|;]", text):
        tokens = [t for t in re.findall(r"[^\s()`'\"]+", segment) if t != "$"]
        if tokens and os.path.basename(tokens[0]) in FOREIGN:
            continue
        command = sub = None
        for i, token in enumerate(tokens):
            base = os.path.basename(token)
            if base in TOOLS or token.startswith("scripts/") or base.endswith((".py", ".sh")):
                command, sub = (base if base in TOOLS else token), None
                if base == "sceneloc" and i + 1 < len(tokens) and \
                        re.match(r"^[a-z]+$", tokens[i + 1]):
                    sub = tokens[i + 1]
                continue
            for flag in FLAG.findall(token):
                out.append((command, sub, flag))
    return out


def source_text(page_dir, command):
    """The text of script `command` as a page in `page_dir` names it, or None."""
    for candidate in (os.path.join(ROOT, command), os.path.join(page_dir, command)):
        if os.path.isfile(candidate):
            return open(candidate, encoding="utf-8").read()
    for folder, _, files in os.walk(page_dir):
        if os.path.basename(command) in files:
            return open(os.path.join(folder, os.path.basename(command)), encoding="utf-8").read()
    return None


def local_flags(page_dir):
    """Flags the sources beside a page (not the root's or docs/) define, e.g. pytest's."""
    if page_dir in (ROOT, os.path.join(ROOT, "docs")):
        return set()
    found = set()
    for folder, _, files in os.walk(page_dir):
        for name in files:
            if name.endswith((".py", ".sh")):
                found |= flags_of(open(os.path.join(folder, name), encoding="utf-8").read())
    return found


def known_flag(flag, known):
    if flag.endswith("-"):  # a family written as --prefix-*
        return any(k.startswith(flag) for k in known)
    return flag in known


def main():
    if len(sys.argv) != 2:
        sys.exit(__doc__)
    build = os.path.abspath(sys.argv[1])
    helps = {}
    for tool, folder in TOOLS.items():
        binary = os.path.join(build, folder, tool)
        if not os.access(binary, os.X_OK):
            sys.exit(f"check_docs: {binary} is not built")
        helps[(tool, None)] = flags_of(help_text(binary))
    client = os.path.join(build, "client", "sceneloc")
    listing = help_text(client)
    subs = re.findall(r"^  ([a-z]+)\s", listing.split("Subcommands:")[-1], re.M)
    for sub in subs:
        helps[("sceneloc", sub)] = flags_of(help_text(client, sub))
    every_flag = set().union(*helps.values())
    known_settings = settings_keys()
    sections = {section for section, _ in known_settings if section}

    problems = []
    for page in PAGES:
        path = os.path.join(ROOT, page)
        if not os.path.exists(path):
            problems.append(f"{page}: missing")
            continue
        fence = False
        with open(path, encoding="utf-8") as f:
            lines = f.read().split("\n")
        page_dir = os.path.dirname(path)
        beside = local_flags(page_dir)
        # The results page and the history record runs as they were made: their links are
        # checked, not their flags and settings.
        record = page in ("docs/results.md", "docs/history.md")
        for number, line in enumerate(lines, 1):
            where = f"{page}:{number}"
            if line.startswith("```"):
                fence = not fence
                continue
            if fence and line.endswith("\\") and number < len(lines):
                lines[number] = line[:-1] + " " + lines[number]  # a continued command
                continue
            spans = [] if record else [line] if fence else re.findall(r"`([^`]+)`", line)
            if not fence:
                for target in LINK.findall(line):
                    if re.match(r"^[a-z]+:", target):
                        continue
                    file, _, fragment = target.partition("#")
                    resolved = os.path.normpath(os.path.join(os.path.dirname(path), file)) \
                        if file else path
                    if not os.path.exists(resolved):
                        problems.append(f"{where}: broken link {target}")
                    elif fragment and resolved.endswith(".md") and \
                            fragment not in headings(resolved):
                        problems.append(f"{where}: no heading '#{fragment}' in {file or page}")
                for section, key in [] if record else SETTING.findall(line):
                    if key in FILE_KINDS:
                        continue
                    if section in sections and (section, key) not in known_settings:
                        problems.append(f"{where}: no setting {section}.{key} in configs/")
            for span in spans:
                for command, sub, flag in command_contexts(span):
                    if command in FOREIGN:
                        continue
                    if command and command not in TOOLS:
                        text = source_text(page_dir, command)
                        if text is None:
                            problems.append(f"{where}: no script {command}")
                        elif flag.rstrip("-") not in text:
                            problems.append(f"{where}: {command} has no {flag}")
                        continue
                    if command == "sceneloc" and sub in subs:
                        known = helps[("sceneloc", sub)]
                    elif command in TOOLS:
                        known = helps[(command, None)]
                    else:
                        known = every_flag | beside
                    if not known_flag(flag, known):
                        problems.append(f"{where}: {' '.join(filter(None, [command, sub]))} "
                                        f"has no flag {flag}".strip())
    for problem in problems:
        print(problem)
    print(f"check_docs: {len(PAGES)} pages, {len(problems)} problem(s)")
    return 1 if problems else 0


if __name__ == "__main__":
    sys.exit(main())
