"""The study's markdown tables as HTML pages for the Snakemake report, which shows HTML results
inline (it offers any other file only as a download): each page is headed by its title and its
caption (the report's ``.rst`` beside this script), then the markdown as HTML. The markdown's
closing provenance comment is kept, so each page carries the record of the table it shows.

Markdown subset of the study's tables and summary: ``#`` headings, paragraphs, ``-`` lists,
``>`` block quotes, pipe tables, inline code, bold, links (shown as their text and target: inside the report, a
relative link leads nowhere)."""

import html
import re
from pathlib import Path

from docutils.core import publish_parts

STYLE = """
body { font: 14px/1.45 system-ui, sans-serif; color: #1e293b; margin: 1.2em 1.6em; }
h1 { font-size: 1.35em; margin: 0 0 .4em; }
h2 { font-size: 1.15em; margin: 1.4em 0 .4em; }
.caption { color: #334155; max-width: 60em; border-left: 3px solid #10b981; padding: .1em .8em;
  margin-bottom: 1.2em; background: #f8fafc; }
.scroll { overflow-x: auto; margin: .6em 0 1em; }
table { border-collapse: collapse; font-size: 13px; }
th, td { border: 1px solid #cbd5e1; padding: .25em .6em; text-align: left; white-space: nowrap; }
th { background: #e2e8f0; position: sticky; top: 0; white-space: normal; vertical-align: bottom; }
td.num { text-align: right; font-variant-numeric: tabular-nums; }
tr:nth-child(even) td { background: #f8fafc; }
code { background: #f1f5f9; padding: 0 .2em; border-radius: 3px; }
blockquote { margin: .8em 0; padding: .4em .9em; border-left: 3px solid #f59e0b;
  background: #fffbeb; max-width: 60em; }
"""
NUMBER = re.compile(r"^[-+−]?(\d+(\.\d*)?|\.\d+)([eE][-+]?\d+)?( ?%)?$")


def inline(text: str) -> str:
    """Escape, then code spans, bold and links (as text and target)."""
    parts = re.split(r"(`[^`]*`)", text)
    out = []
    for part in parts:
        if part.startswith("`") and part.endswith("`") and len(part) > 1:
            out.append(f"<code>{html.escape(part[1:-1])}</code>")
            continue
        part = html.escape(part)
        part = re.sub(r"\*\*(.+?)\*\*", r"<strong>\1</strong>", part)
        part = re.sub(r"\[([^\]]+)\]\(([^)]+)\)", r"\1 (<code>\2</code>)", part)
        out.append(part)
    return "".join(out)


def _cells(line: str) -> list[str]:
    return [cell.strip() for cell in line.strip().strip("|").split("|")]


def _table(lines: list[str]) -> str:
    header, rows = _cells(lines[0]), [_cells(line) for line in lines[2:]]
    # Long column names (final_mean_deploy_success_rate) may break after an underscore.
    head = "".join(f"<th>{inline(cell).replace('_', '_<wbr>')}</th>" for cell in header)
    body = "".join(
        "<tr>"
        + "".join(
            f'<td class="num">{inline(c)}</td>' if NUMBER.match(c) else f"<td>{inline(c)}</td>"
            for c in row
        )
        + "</tr>"
        for row in rows
    )
    table = f"<table><thead><tr>{head}</tr></thead><tbody>{body}</tbody></table>"
    return f'<div class="scroll">{table}</div>'


def markdown_html(text: str) -> str:
    """The markdown subset above as an HTML fragment."""
    blocks, lines = [], text.splitlines()
    k = 0
    while k < len(lines):
        line = lines[k]
        if not line.strip():
            k += 1
        elif line.startswith("<!--"):
            blocks.append(line)
            k += 1
        elif line.startswith("#"):
            level = min(len(line) - len(line.lstrip("#")), 6)
            blocks.append(f"<h{level}>{inline(line[level:].strip())}</h{level}>")
            k += 1
        elif line.startswith("|"):
            start = k
            while k < len(lines) and lines[k].startswith("|"):
                k += 1
            blocks.append(_table(lines[start:k]))
        elif line.startswith(">"):
            quoted = []
            while k < len(lines) and lines[k].startswith(">"):
                quoted.append(lines[k][1:].strip())
                k += 1
            blocks.append(f"<blockquote><p>{inline(' '.join(quoted))}</p></blockquote>")
        elif line.startswith("- "):
            items = []
            while k < len(lines) and lines[k].strip() and not lines[k].startswith("|"):
                if lines[k].startswith("- "):
                    items.append(lines[k][2:].strip())
                else:
                    items[-1] += " " + lines[k].strip()
                k += 1
            blocks.append("<ul>" + "".join(f"<li>{inline(i)}</li>" for i in items) + "</ul>")
        else:
            start = k
            while (
                k < len(lines)
                and lines[k].strip()
                and not lines[k].startswith(("|", "#", "<!--", ">"))
            ):
                k += 1
            blocks.append(f"<p>{inline(' '.join(x.strip() for x in lines[start:k]))}</p>")
    return "\n".join(blocks)


def page(title: str, caption_rst: str, markdown: str) -> str:
    """A standalone HTML page: title, caption (reStructuredText), the markdown as HTML; the
    markdown's closing comments (its provenance record) close the page too."""
    caption = publish_parts(caption_rst, writer_name="html")["body"] if caption_rst else ""
    lines = markdown.rstrip().splitlines()
    closing = []
    while lines and lines[-1].startswith("<!--"):
        closing.insert(0, lines.pop())
    body = markdown_html("\n".join(lines))
    return (
        '<!doctype html>\n<html lang="en"><head><meta charset="utf-8">'
        f"<title>{html.escape(title)}</title><style>{STYLE}</style></head><body>\n"
        f'<h1>{html.escape(title)}</h1>\n<div class="caption">{caption}</div>\n'
        f"{body}\n</body></html>\n" + "".join(f"{line}\n" for line in closing)
    )


if "snakemake" in globals():
    from pih.records.outputs import write_text
    from pih.workflow.jobs import logged

    with logged(snakemake.log[0]):  # noqa: F821 - the object Snakemake gives its scripts
        for name, source in snakemake.input.items():  # noqa: F821
            title, caption = snakemake.params.pages[name]  # noqa: F821
            caption_rst = (Path(snakemake.scriptdir) / caption).read_text()  # noqa: F821
            text = Path(source).read_text().lstrip()
            if text.startswith("# "):  # a file's own title (e.g. the summary's) heads its page
                first, _, text = text.partition("\n")
                title = first[2:].strip()
            target = getattr(snakemake.output, name)  # noqa: F821
            write_text(target, page(title, caption_rst, text))
            print(f"{source} -> {target}")
