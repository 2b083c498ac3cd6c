"""What the tests check on every web page of the project (the console, the
fleet map): the page and its files load from the server itself."""

import re

import pytest

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


async def check_token_required(client, token, routes):
    """Every route refuses a request without the token or with a wrong or
    cut one (401, the error naming the token) and serves one that brings
    it in the Authorization header or in the address."""
    for headers, query, status in (
            ({}, "", 401),
            ({"Authorization": "Bearer wrong"}, "", 401),
            ({"Authorization": "Bearer " + token[:-1]}, "", 401),
            ({}, "?token=" + token[:-1], 401),
            ({}, "?token=" + token + "x", 401),
            ({"Authorization": "Bearer " + token}, "", 200),
            ({}, "?token=" + token, 200)):
        for route in routes:
            client.session.cookie_jar.clear()
            r = await client.get(route + query, headers=headers)
            assert r.status == status, (route, headers, query)
            if status == 401:
                assert "token" in (await r.json())["error"]
    client.session.cookie_jar.clear()


async def check_loopback_guard(client, route):
    """On loopback without a token: ``route`` and the socket refuse another
    host (DNS rebinding) or another page's origin (403) and ``route``
    serves a loopback host."""
    import aiohttp
    r = await client.get(route, headers={"Host": "attacker.example:80"})
    assert r.status == 403
    with pytest.raises(aiohttp.WSServerHandshakeError) as err:
        await client.ws_connect(
            "/ws", headers={"Origin": "http://attacker.example"})
    assert err.value.status == 403
    r = await client.get(route, headers={"Host": "localhost:1"})
    assert r.status == 200
