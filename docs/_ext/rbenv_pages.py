"""A Sphinx extension that writes the site's reference pages from the code before it is read.

* ``reference/envs/<Name>.md``: one page per registered ``rbenv/`` id, from the registry and the
  env class's docstring (arguments, observation, reward, episode end, Version History), with
  its spaces on its default scene and an animation of one seeded episode of its scripted
  baseline, rendered by rbenv (``render_mode="rgb_array"``) at build time.
* ``reference/scenes/<name>.md``: one page per shipped scene, from its TOML file and the
  schema (:mod:`rbenv.satellite.scene_schema`: each key's unit and meaning), with the derived
  mass properties and the sources the file quotes.

The pages are written only where their text changed, so an incremental build stays
incremental. The folders are generated (git ignores them).
"""

from __future__ import annotations

import inspect
import re
import textwrap
import warnings
from pathlib import Path

try:
    import tomllib
except ModuleNotFoundError:  # Python 3.10
    import tomli as tomllib

import gymnasium as gym
import numpy as np

import rbenv
from rbenv.satellite import scene_schema
from rbenv.satellite.scene import load_scene

GIF_STEPS = 80  # control steps shown per animation (most shipped episodes settle within it)
GIF_SIZE = 240  # px, the animation's side (the renderer draws 480; every second pixel kept)


def setup(app):
    app.connect("builder-inited", _generate)
    app.connect("source-read", _site_links)
    app.connect("include-read", _readme_links)
    app.connect("autodoc-process-docstring", _escape_docstring)
    return {"version": "1", "parallel_read_safe": True, "parallel_write_safe": True}


def _generate(app) -> None:
    warnings.filterwarnings("ignore", message=".*is out of date", category=DeprecationWarning)
    root = Path(app.srcdir) / "reference"
    env_ids = sorted(k for k in gym.registry if k.startswith("rbenv/"))
    _write(root / "envs" / "index.md", _env_index(env_ids))
    for env_id in env_ids:
        name = _page_name(env_id)
        media = root / "envs" / "media" / f"{name}.gif"
        if not media.exists():
            _animate(env_id, media)
        _write(root / "envs" / f"{name}.md", _env_page(env_id, media.name))
    scenes = rbenv.list_scenes()
    _write(root / "scenes" / "index.md", _scene_index(scenes))
    _copy_results(Path(app.srcdir), root / "results")
    for scene in scenes:
        _write(root / "scenes" / f"{scene}.md", _scene_page(scene))


RESULT_PAGES = ("fidelity/fidelity.md", "suite/suite.md", "robustness/robustness.md")


def _copy_results(srcdir: Path, out: Path) -> None:
    """The benchmark tables the guides link to, as pages of the site (with their figures)."""
    bench = srcdir.parent / "benchmarks" / "results"
    for rel in RESULT_PAGES:
        page = bench / rel
        text = page.read_text()
        if not text.startswith("# "):
            title = page.stem.capitalize()
            text = f"# {title}: the benchmark's table\n\n`benchmarks/results/{rel}`\n\n{text}"
        _write(out / rel, text)
        for image in page.parent.glob("*.png"):
            target = out / rel.split("/")[0] / image.name
            if not target.exists() or target.read_bytes() != image.read_bytes():
                target.write_bytes(image.read_bytes())


def _write(path: Path, text: str) -> None:
    path.parent.mkdir(parents=True, exist_ok=True)
    if not path.exists() or path.read_text() != text:
        path.write_text(text)


def _scene_of(env):
    """The Scene an env (or the goal env around one) runs."""
    base = env.unwrapped
    plant = getattr(base, "plant", None) or base.env.unwrapped.plant
    return plant.scene


def _page_name(env_id: str) -> str:
    return env_id.split("/", 1)[1]


_LITERAL = re.compile(r"(``.+?``)")
_GRID_LINE = re.compile(r"^\s*(\+[-=+]+\+|\|.*\|)\s*$")


def escape_bars(text: str) -> str:
    """reStructuredText of a docstring with its math bars (``|ω|``, a norm) escaped: plain
    docstrings use them, and docutils would read ``|ω|`` as a substitution. Inline literals and
    grid-table lines are left as they are."""
    out = []
    for line in text.split("\n"):
        if _GRID_LINE.match(line):
            out.append(line)
            continue
        parts = _LITERAL.split(line)
        out.append("".join(p if i % 2 else p.replace("|", "\\|")
                           for i, p in enumerate(parts)))
    return "\n".join(out)


def _escape_docstring(app, what, name, obj, options, lines) -> None:
    lines[:] = escape_bars("\n".join(lines)).split("\n")


_LINK = re.compile(r"\[([^\]]+)\]\(([^)\s]+)\)")


def _site_links(app, docname, source) -> None:
    """Links that read well in the repository but name no page of the site: a folder (the
    site has no folder listings) becomes its label, and a result page under benchmarks/ (outside
    the site's source) a link to the copy that :func:`_generate` puts under reference/."""
    page = Path(app.srcdir) / docname

    def link(match):
        label, target = match.groups()
        if "://" in target or target.startswith("#"):
            return match.group(0)
        resolved = (page.parent / target).resolve()
        if target.endswith("/") and resolved.is_dir():
            return label
        bench = Path(app.srcdir).parent / "benchmarks" / "results"
        if resolved.suffix == ".md" and resolved.is_relative_to(bench):
            return f"[{label}](/reference/results/{resolved.relative_to(bench).as_posix()})"
        return match.group(0)

    source[0] = _LINK.sub(link, source[0])


def _readme_links(app, relative_path, parent_docname, content) -> None:
    """The README, included as the landing page: its link to the changelog at the repository's
    root goes to the changelog's page of the site."""
    if Path(relative_path).name == "README.md":
        content[0] = content[0].replace("](CHANGELOG.md)", "](docs/changelog.md)")


# ---------------------------------------------------------------------------- env pages


def _env_index(env_ids: list[str]) -> str:
    rows = ["| id | what it asks | default scene |", "|---|---|---|"]
    for env_id in env_ids:
        env = gym.make(env_id)
        summary = _summary(env)
        scene = _scene_of(env).name
        env.close()
        rows.append(f"| [`{env_id}`]({_page_name(env_id)}.md) | {summary} | "
                    f"[{scene}](../scenes/{scene}.md) |")
    toc = "\n".join(_page_name(e) for e in env_ids)
    return f"""# Environments

Every id that `import rbenv` registers, generated from the registry and each env's docstring.
The older ids stay registered and bit-identical for their committed results; the highest
version of each task is its current one (`rbenv.ENV_ID`: Reorient-v2).

{chr(10).join(rows)}

```{{toctree}}
:hidden:

{toc}
```
"""


def _summary(env) -> str:
    doc = inspect.getdoc(type(env.unwrapped)) or ""
    return doc.split("\n", 1)[0].rstrip(".").replace("|", "\\|")


def _env_page(env_id: str, gif: str) -> str:
    env = gym.make(env_id)
    base, scene = env.unwrapped, _scene_of(env)
    doc = inspect.getdoc(type(base)) or ""
    first, _, rest = doc.partition("\n")
    spec = gym.spec(env_id)
    facts = [
        ("import", f"`gym.make(\"{env_id}\")`, `gym.make_vec(\"{env_id}\", num_envs=N)`"),
        ("default scene", f"[{scene.name}](../scenes/{scene.name}.md)"),
        ("action space", f"`{_space(env.action_space)}`"),
        ("observation space", f"`{_space(env.observation_space)}`"),
        ("episode steps", f"at most {spec.max_episode_steps} (the scene may end it sooner)"),
        ("control step", f"{scene.physics.control_dt:g} s"),
    ]
    env.close()
    table = "\n".join(["| | |", "|---|---|", *(f"| {k} | {v} |" for k, v in facts)])
    return f"""# {env_id}

{first.strip()}

```{{image}} media/{gif}
:alt: one seeded episode of {env_id} on its default scene
:width: {GIF_SIZE}px
```

{table}

```{{eval-rst}}
{escape_bars(textwrap.dedent(rest).strip())}
```
"""


def _space(space) -> str:
    if isinstance(space, gym.spaces.Dict):
        return "Dict(" + ", ".join(f"{k}: {_space(v)}" for k, v in space.spaces.items()) + ")"
    return str(space)


def _animate(env_id: str, path: Path) -> None:
    """One seeded episode of the env's scripted PD (random actions where it has none)."""
    from rbenv.agents.policies.evaluate import make_policy, scripted

    from rbenv.envs.rendering import save_video

    env = gym.make(env_id, render_mode="rgb_array")
    try:
        policy = make_policy("pd" if "pd" in scripted(env_id) else "random", env, 0)
    except ValueError:  # an id without scripted baselines (the goal env): random actions
        env.action_space.seed(0)
        policy = None
    obs, _ = env.reset(seed=0)
    frames, state = [env.render()[::2, ::2]], None
    for _ in range(GIF_STEPS):
        if policy is None:
            action = env.action_space.sample()
        else:
            action, state = policy.predict(obs, state=state, deterministic=True)
        obs, _, term, trunc, _ = env.step(action)
        frames.append(env.render()[::2, ::2])
        if term or trunc:
            break
    env.close()
    path.parent.mkdir(parents=True, exist_ok=True)
    save_video([np.ascontiguousarray(f) for f in frames], path, fps=8)


# -------------------------------------------------------------------------- scene pages


def _scene_index(scenes: list[str]) -> str:
    rows = ["| scene | mass | actuators | what it is |", "|---|---|---|---|"]
    for name in scenes:
        sc = load_scene(name)
        about = sc.description.split(":")[0].split("(")[0].strip().replace("|", "\\|")
        rows.append(f"| [{name}]({name}.md) | {sc.body.mass:g} kg | "
                    f"{', '.join(sorted(sc.actuators))} | {about} |")
    toc = "\n".join(scenes)
    return f"""# Scenes

The satellites shipped with rbenv, generated from their TOML files (`rbenv/scenes/`) and the
scene schema. A scene of your own is a TOML file with the same tables: see
[the scene file reference](../../scenes.md).

{chr(10).join(rows)}

```{{toctree}}
:hidden:

{toc}
```
"""


def _scene_page(name: str) -> str:
    sc = load_scene(name)
    path = Path(rbenv.__file__).parent / "scenes" / f"{name}.toml"
    text = path.read_text()
    data = tomllib.loads(text)
    inertia = np.array2string(np.asarray(sc.body.inertia), precision=5, separator=", ")
    lines = [f"# {name}", "", sc.description.replace("\\\n", ""), "",
             "| | |", "|---|---|",
             f"| mass | {sc.body.mass:g} kg |",
             f"| inertia about the centre of mass, body axes | `{' '.join(inertia.split())}` "
             "kg m² |",
             f"| actuators | {', '.join(f'`[{a}]`' for a in sorted(sc.actuators))} |",
             f"| integrator, control step | {sc.physics.integrator}, "
             f"{sc.physics.control_dt:g} s |", ""]
    lines += _key_tables(data)
    sources = data.get("sources", [])
    if sources:
        lines += ["## Sources", "", *(f"- {s}" for s in sources), ""]
    lines += ["## The file", "", "```toml", text.rstrip(), "```", ""]
    return "\n".join(lines)


def _key_tables(data: dict) -> list[str]:
    """Each table of the file with its keys' values, units and meanings from the schema."""
    schema = {t.header: {k.name: k for k in t.keys} for t in scene_schema.TABLES}
    out = ["## Tables", ""]
    for header, table in data.items():
        if not isinstance(table, dict) or header == "tasks":
            continue
        keys = schema.get(f"[{header}]", {})
        out += [f"### `[{header}]`", "", "| key | value | unit | meaning |", "|---|---|---|---|"]
        for key, value in table.items():
            k = keys.get(key)
            unit, meaning = (k.unit or "—", k.meaning) if k else ("—", "")
            shown = str(value).replace("|", "\\|")
            out.append(f"| `{key}` | `{shown}` | {unit} | {meaning.replace('|', chr(92) + '|')} |")
        out.append("")
    if "tasks" in data:
        out += ["### `[tasks.*]`", "", "Per-task tables (see the scene file reference):", "",
                "```toml", *_toml_lines({"tasks": data["tasks"]}), "```", ""]
    return out


def _toml_lines(data: dict, prefix: str = "") -> list[str]:
    lines: list[str] = []
    for key, value in data.items():
        if isinstance(value, dict):
            lines += _toml_lines(value, f"{prefix}{key}.")
        else:
            lines.append(f"{prefix}{key} = {value!r}")
    return lines
