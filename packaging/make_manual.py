#!/usr/bin/env python3
"""The manual page and the bash completion of nvstim, made from the built binary's own help.

    make_manual.py NVSTIM OUT_DIR

writes OUT_DIR/nvstim.1 (troff, man(7) macros) and OUT_DIR/nvstim.bash (a bash completion).
Both come from `nvstim --help` and `nvstim SUBCOMMAND --help` (CLI11's layout: "Positionals:",
"Options:", "Subcommands:" sections), so neither can drift from the options the binary takes.
"""
import re
import subprocess
import sys
from pathlib import Path


def help_text(nvstim, *args):
    r = subprocess.run([nvstim, *args, "--help"], capture_output=True, text=True, check=False)
    if r.returncode != 0:
        sys.exit(f"make_manual.py: {nvstim} {' '.join(args)} --help: exit {r.returncode}")
    return r.stdout


def sections(text):
    """Splits CLI11 help into (preamble lines, {section: [entry lines]}, epilogue lines): a
    section's entries are indented; the first unindented line after a blank ends the sections."""
    pre, secs, epi = [], {}, []
    cur = None
    for line in text.splitlines():
        m = re.match(r"^(Positionals|Options|Subcommands):$", line)
        if m and not epi:
            cur = m.group(1)
            secs[cur] = []
        elif cur is None:
            pre.append(line)
        elif line.startswith("  ") and not epi:
            secs[cur].append(line)
        elif line:
            epi.append(line)
    return pre, secs, epi


def entries(lines):
    """CLI11 entries: ('--output TEXT ...', 'description'), continuation lines joined."""
    out = []
    for line in lines:
        body = line.strip()
        if not body:
            continue
        indent = len(line) - len(line.lstrip())
        if indent > 4 and out:  # a description on its own line, or its continuation
            name, desc = out[-1]
            out[-1] = (name, (desc + " " + body).strip())
            continue
        parts = re.split(r"\s{2,}", body, maxsplit=1)
        out.append((parts[0], parts[1] if len(parts) > 1 else ""))
    return out


def esc(text):
    """Text safe in a troff line: backslashes, leading dots and quotes, hyphens as minus signs
    in option names."""
    t = text.replace("\\", "\\e")
    t = t.replace("-", "\\-")
    if t.startswith(".") or t.startswith("'"):
        t = "\\&" + t
    return t


def option_names(entry_name):
    """'-h,--help' → ['-h', '--help']; '--clock TEXT:{wall,sim}=wall' → ['--clock']."""
    first = entry_name.split(" ")[0]
    return [n for n in first.split(",") if n.startswith("-")]


def main():
    if len(sys.argv) != 3:
        sys.exit(__doc__)
    nvstim, out_dir = sys.argv[1], Path(sys.argv[2])
    out_dir.mkdir(parents=True, exist_ok=True)
    top = help_text(nvstim)
    pre, secs, epi = sections(top)
    subs = entries(secs.get("Subcommands", []))
    version = subprocess.run([nvstim, "--version"], capture_output=True, text=True).stdout.strip()

    man = [
        '.TH NVSTIM 1 "" "nvstim %s" "User Commands"' % esc(version.split()[-1] if version else ""),
        ".SH NAME",
        "nvstim \\- " + esc(pre[0].split("—", 1)[-1].strip() if pre else "night-vision stimulator"),
        ".SH SYNOPSIS",
        ".B nvstim",
        ".I SUBCOMMAND",
        "[\\fIOPTIONS\\fR]",
        ".SH DESCRIPTION",
    ]
    man += [esc(line) for line in pre[1:] if line and not line.startswith("Usage:")]
    man += [
        ".PP",
        "The shipped camera presets and scenarios are listed by \\fBnvstim list presets\\fR and "
        "\\fBnvstim list scenarios\\fR; a scenario can be named without its folder.",
        ".SH COMMANDS",
    ]
    completion = {}
    for name, desc in subs:
        text = help_text(nvstim, name)
        spre, ssecs, sepi = sections(text)
        usage = next((l for l in spre if l.startswith("Usage:")), "")
        man += [".SS " + esc(name), esc(desc), ".PP", ".B " + esc(usage[len("Usage: "):])]
        for title in ("Positionals", "Options"):
            ents = entries(ssecs.get(title, []))
            if not ents:
                continue
            for ename, edesc in ents:
                man += [".TP", ".B " + esc(ename), esc(edesc) if edesc else ""]
        if sepi:
            man += [".PP"] + [esc(l) for l in sepi]
        opts = []
        for ename, _ in entries(ssecs.get("Options", [])):
            opts += option_names(ename)
        # A subcommand's own subcommands (nvstim list presets|scenarios).
        inner = [n for n, _ in entries(ssecs.get("Subcommands", []))]
        completion[name] = (opts, inner)
    man += [".SH EXIT STATUS"] + [esc(l) for l in epi if not l.startswith("Run `")]
    man += [
        ".SH ENVIRONMENT",
        ".TP",
        ".B NVS_CONFIG_DIR",
        "The folder of camera presets, spectra and tables (default: "
        "\\fI<bindir>/../share/nvstim/config\\fR).",
        ".TP",
        ".B NVS_CACHE_DIR",
        "Disk caches (default: \\fI$XDG_CACHE_HOME/nvstim\\fR, else \\fI~/.cache/nvstim\\fR).",
        ".SH FILES",
        ".TP",
        ".I /usr/share/nvstim/config",
        "Camera presets (\\fIcameras/\\fR, \\fIthermal_cameras/\\fR), spectra, atmosphere and "
        "star tables.",
        ".TP",
        ".I /usr/share/nvstim/scenarios",
        "The shipped scenarios.",
        ".SH SEE ALSO",
        "\\fBgst\\-inspect\\-1.0\\fR(1) nvstimsrc; \\fBpython3\\fR(1) \\-c 'import nvstim'; "
        "\\fI/usr/share/doc/nvstim\\fR.",
    ]
    (out_dir / "nvstim.1").write_text("\n".join(man) + "\n")

    # The completion: subcommands, each one's options, files for paths, and the names
    # `nvstim list` knows for --camera and a scenario argument.
    cases = []
    for name, (opts, inner) in completion.items():
        words = " ".join(opts + inner)
        cases.append(f"        {name}) opts=\"{words}\" ;;")
    script = f"""# bash completion for nvstim (made from `nvstim --help` by packaging/make_manual.py)
_nvstim() {{
    local cur prev sub opts i
    cur="${{COMP_WORDS[COMP_CWORD]}}"
    prev="${{COMP_WORDS[COMP_CWORD-1]}}"
    sub=""
    for ((i = 1; i < COMP_CWORD; i++)); do
        case "${{COMP_WORDS[i]}}" in
            -*) ;;
            *) sub="${{COMP_WORDS[i]}}"; break ;;
        esac
    done
    if [[ -z "$sub" ]]; then
        COMPREPLY=($(compgen -W "{' '.join(completion)} --help --version" -- "$cur"))
        return
    fi
    case "$prev" in
        --camera)
            COMPREPLY=($(compgen -W "$(nvstim list presets --names 2>/dev/null)" -- "$cur"))
            compopt -o filenames 2>/dev/null
            COMPREPLY+=($(compgen -f -X '!*.toml' -- "$cur"))
            return ;;
        --clock)
            COMPREPLY=($(compgen -W "wall sim" -- "$cur")); return ;;
        --output|--stats|--json|--report|--out|--in|--telemetry|--write-preset)
            compopt -o filenames 2>/dev/null
            COMPREPLY=($(compgen -f -- "$cur")); return ;;
    esac
    case "$sub" in
{chr(10).join(cases)}
        *) opts="" ;;
    esac
    if [[ "$cur" == -* ]]; then
        COMPREPLY=($(compgen -W "$opts" -- "$cur"))
        return
    fi
    case "$sub" in
        list) COMPREPLY=($(compgen -W "$opts" -- "$cur")) ;;
        run|render|replay)
            COMPREPLY=($(compgen -W "$(nvstim list scenarios --names 2>/dev/null)" -- "$cur"))
            compopt -o filenames 2>/dev/null
            COMPREPLY+=($(compgen -f -- "$cur")) ;;
        *)
            compopt -o filenames 2>/dev/null
            COMPREPLY=($(compgen -f -- "$cur")) ;;
    esac
}}
complete -F _nvstim nvstim
"""
    (out_dir / "nvstim.bash").write_text(script)


if __name__ == "__main__":
    main()
