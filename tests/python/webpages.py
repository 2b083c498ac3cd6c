"""What the tests check on every web page of the project (the console, the
fleet map): the page and its files load from the server itself."""

import re

# nothing fetched from elsewhere: no scheme, no protocol-relative URL, no
# CSS import or url() (lower case: the scripts' ``new URL(`` is fine)
NO_EXTERNAL = re.compile(r"(?i:(?:https?|wss?|ftp)://|[\"'(]//\w|@import)|"
                         r"\burl\(")


async def check_self_contained(client, files, outside):
    """Fetches the page and every static/ file it references (``files``
    among them), asserts all load and none names another site, and that
    ``outside`` (a path out of static/) is refused. Returns the page."""
    r = await client.get("/")
    assert r.status == 200
    html = await r.text()
    refs = re.findall(r'(?:src|href)="([^"]+)"', html)
    assert set(files) <= set(refs)
    texts = {"index.html": html}
    for ref in refs:
        if ref.startswith("static/"):
            r = await client.get("/" + ref)
            assert r.status == 200, ref
            texts[ref] = await r.text()
    for name, text in texts.items():
        assert not NO_EXTERNAL.search(text), name
    r = await client.get(outside)
    assert r.status in (403, 404)
    return html
