"""The mock identity manager: tokens, sessions, setup state, and Problems for the rest.

The mock knows one fixed set of users and no user, group, role or provider
management. Every other operation of the published description (v2.10.0)
is routed and answers a Problem with a status the description lists for it:
401 without a valid token where the operation needs one, else 403 (404 for
the per-user settings, which list no 403).
"""

from __future__ import annotations

from urllib.parse import urlencode

from aiohttp import web
from aiohttp.typedefs import Handler

from .problems import request_problem
from .state import STATE_KEY, bearer_token

SESSION_COOKIE = "CTRLX-OS-SESSION-ID"
"""The description's ``CookieAuth``: ``GET /auth/token`` trades it for the session's token."""

UNSERVED: dict[str, str] = {
    "/settings/easyserviceaccess": "GET PUT",
    "/settings/loginbanner": "GET PUT",
    "/settings/session": "GET PUT",
    "/sessions": "GET",
    "/sessions/{id}": "DELETE GET",
    "/systemusergen": "POST",
    "/setup": "POST",
    "/users": "GET POST",
    "/users/{id}": "DELETE GET PUT",
    "/users/{id}/locked": "PUT",
    "/users/{id}/credentials": "GET PUT",
    "/users/{id}/membership": "GET POST PUT",
    "/users/{id}/membership/{groupid}": "DELETE",
    "/users/{id}/scopes": "GET PUT",
    "/users/{id}/settings": "GET PATCH PUT",
    "/password-policies": "GET POST",
    "/password-policies/{policyId}": "DELETE GET PUT",
    "/users/{id}/pwdchgatnextlogin": "GET PUT",
    "/self/password-policy": "GET",
    "/groups": "GET POST",
    "/groups/{id}": "DELETE GET",
    "/groups/{id}/members": "GET POST PUT",
    "/groups/{id}/members/{userid}": "DELETE",
    "/groups/{id}/scopes": "GET PUT",
    "/roles": "GET POST",
    "/roles/{id}": "DELETE GET PUT",
    "/roles/{id}/scopes": "GET PUT",
    "/scopes": "GET",
    "/scopes/{identifier}/users": "GET PUT",
    "/scopes/{identifier}/groups": "GET PUT",
    "/scopes/{identifier}/roles": "GET PUT",
    "/apps": "GET",
    "/apps/{applicationId}/scopes": "GET",
    "/apps/{applicationId}/dynamic-scopes": "GET PUT",
    "/apps/{applicationId}/requested-scopes": "GET",
    "/policies/users/reservednames": "GET",
    "/policies/users/passwords": "GET PUT",
    "/policies/groups/reservednames": "GET",
    "/loginLockedStatus/users": "GET",
    "/loginLockedStatus/users/{id}": "PUT",
    "/remote-auth/config": "GET PUT",
    "/remote-auth/services": "GET",
    "/remote-auth/services/radius/config": "GET PUT",
    "/remote-auth/services/radius/auth-protocols": "GET",
    "/remote-auth/services/ldap/config": "GET PUT",
    "/remote-auth/services/oidc/providers": "GET POST",
    "/remote-auth/services/oidc/providers/{id}": "DELETE GET PUT",
}
"""Operations of the description the mock does not provide: path template -> methods."""

PUBLIC = {("GET", "/settings/loginbanner"), ("POST", "/setup"), ("GET", "/remote-auth/config")}
"""Operations the description marks as needing no authentication."""
NO_401 = {("GET", "/users/{id}/credentials")}
NOT_FOUND = {"/users/{id}/settings"}


async def create_token(request: web.Request) -> web.Response:
    """POST /auth/token: 201 with a bearer token (and a session cookie), 401 Problem if wrong."""
    try:
        body = await request.json()
        user, password = body["name"], body["password"]
        if not isinstance(user, str) or not isinstance(password, str):
            raise TypeError
    except (ValueError, KeyError, TypeError):
        return request_problem(request, 400, "Bad Request", "expected JSON 'name' and 'password'")
    tokens = request.app[STATE_KEY].tokens
    token = tokens.issue(user, password)
    if token is None:
        return request_problem(request, 401, "Unauthorized", "wrong user name or password")
    if request.query.get("dryrun") == "true":
        return web.Response(status=204)
    response = web.json_response({"access_token": token, "token_type": "Bearer"}, status=201)
    response.set_cookie(
        SESSION_COOKIE,
        tokens.open_session(token),
        path="/identity-manager",
        httponly=True,
        samesite="Strict",
        secure=request.secure,
    )
    return response


async def get_token(request: web.Request) -> web.Response:
    """GET /auth/token: the token of the session cookie, 401 Problem without a live session."""
    session = request.cookies.get(SESSION_COOKIE)
    token = None if session is None else request.app[STATE_KEY].tokens.session_token(session)
    if token is None:
        return request_problem(request, 401, "Unauthorized", "no valid session cookie")
    return web.json_response({"access_token": token, "token_type": "Bearer"})


async def delete_token(request: web.Request) -> web.Response:
    """DELETE /auth/token: revoke the bearer token (204 whatever it was)."""
    token = bearer_token(request)
    if token is not None:
        request.app[STATE_KEY].tokens.revoke(token)
    return web.Response(status=204)


async def token_validity(request: web.Request) -> web.Response:
    """GET /auth/token/validity: whether the bearer token is still accepted."""
    token = bearer_token(request)
    valid = token is not None and request.app[STATE_KEY].tokens.check(token) is None
    return web.json_response({"valid": valid})


async def setup_state(request: web.Request) -> web.Response:
    """GET /setup/state: the initial setup is done (the mock's users are fixed)."""
    return web.json_response({"state": "completed"})


async def oidc_login(request: web.Request) -> web.Response:
    """GET /auth/oidc/login: 302, as described; to the callback, since no provider exists."""
    base = request.path.rsplit("/login", 1)[0]
    query = urlencode({"code": "", "provider-id": request.query.get("provider-id", "")})
    raise web.HTTPFound(f"{base}/callback?{query}")


async def oidc_callback(request: web.Request) -> web.Response:
    """GET /auth/oidc/callback: 400 Problem, the mock has no OpenID Connect provider."""
    provider = request.query.get("provider-id", "")
    detail = "no OpenID Connect provider is configured on the mock"
    return request_problem(request, 400, "Bad Request", detail, dynamic=provider)


def unserved(template: str, method: str) -> Handler:
    """The handler of an operation the mock does not provide."""

    async def handler(request: web.Request) -> web.Response:
        token = bearer_token(request)
        authorized = token is not None and request.app[STATE_KEY].tokens.check(token) is None
        if (method, template) in PUBLIC or (method, template) in NO_401 or authorized:
            status, title = (404, "Not Found") if template in NOT_FOUND else (403, "Forbidden")
            detail = f"the mock ctrlX does not provide {method} {template}"
            return request_problem(request, status, title, detail)
        return request_problem(request, 401, "Unauthorized", "a valid bearer token is required")

    return handler
