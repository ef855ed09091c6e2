"""``iwz secure``: a certificate authority, an identity per process, the router's configuration.

iwz secure init DIR                                  the authority (DIR/ca.crt, DIR/ca.key)
iwz secure issue NAME --role ROLE [--dir DIR] ...    NAME.crt, NAME.key; NAME joins DIR/policy.toml
iwz secure config POLICY --identity DIR/router       the router's Zenoh configuration (JSON5)
"""

from __future__ import annotations

import argparse
import json
import sys
from collections.abc import Sequence
from pathlib import Path

from iw_zenoh import keys
from iw_zenoh.bus.net import DEFAULT_TLS_ENDPOINT, NetConfig, config_values
from iw_zenoh.errors import ConfigError, IwError
from iw_zenoh.secure.certs import init_ca, issue
from iw_zenoh.secure.grants import POLICY_ROLES
from iw_zenoh.secure.policy import load_policy, parse_policy

__all__ = ["add_identity", "main"]

POLICY_FILE = "policy.toml"
HEADER = '# iw-zenoh security policy (docs/security.md): who plays which role\nsim = "{sim}"\n'

EPILOG = """\
Examples (two laptops on a lab Wi-Fi, the router on 192.168.1.10):
  iwz secure init ids
  iwz secure issue router --role router --dir ids --host 192.168.1.10
  iwz secure issue world --role world --dir ids
  iwz secure issue alice --role agent --robots 1,2 --dir ids
  iwz secure issue sensors-1 --role sensors --shard 1/2 --dir ids
  iwz router --identity ids/router --policy ids/policy.toml --listen tls/0.0.0.0:7447
  iwz world maps/liacc.xml --identity ids/world --connect tls/192.168.1.10:7447
  iwz secure config ids/policy.toml --identity ids/router -o router.json5
Each process gets its NAME.crt and NAME.key and ca.crt; never copy ca.key off the machine that issues.
"""


def _parser() -> argparse.ArgumentParser:
    p = argparse.ArgumentParser(
        prog="iwz secure",
        description="Identities for a secured simulation: a certificate authority, a certificate per process "
        "(its common name is its name), the policy saying what each may do, the router's configuration.",
        epilog=EPILOG,
        formatter_class=argparse.RawDescriptionHelpFormatter,
    )
    sub = p.add_subparsers(dest="command", required=True)
    i = sub.add_parser("init", help="make a certificate authority in DIR", epilog="Example: iwz secure init ids")
    i.add_argument("dir", metavar="DIR")
    i.add_argument("--force", action="store_true", help="replace an authority already there")
    i.add_argument("--sim", default="default", help="the simulation the policy guards (default: default)")
    s = sub.add_parser(
        "issue",
        help="issue the identity NAME and add it to the policy",
        epilog="Example: iwz secure issue alice --role agent --robots 1,2 --dir ids",
    )
    s.add_argument("name", metavar="NAME", help="the identity: the certificate's common name, the process's --name")
    roles = [*POLICY_ROLES, "router"]
    s.add_argument("--role", required=True, action="append", choices=roles, help="its role (repeatable)")
    s.add_argument("--dir", default=".", help="the authority's folder (default: here)")
    s.add_argument("--robots", default="", metavar="ID,ID", help="an agent's robots")
    s.add_argument("--shard", default="", metavar="K/N", help="a sensors process's shard (default: any)")
    s.add_argument("--host", action="append", default=[], help="another name or address it is reached at (repeatable)")
    s.add_argument("--policy", help=f"the policy to add it to (default DIR/{POLICY_FILE})")
    c = sub.add_parser(
        "config",
        help="write the router's Zenoh configuration for a policy",
        epilog="Example: iwz secure config ids/policy.toml --identity ids/router -o router.json5",
    )
    c.add_argument("policy", metavar="POLICY")
    c.add_argument("--identity", required=True, metavar="DIR/NAME", help="the router's identity")
    c.add_argument("--listen", action="append", default=[], help=f"endpoint (default {DEFAULT_TLS_ENDPOINT})")
    c.add_argument("-o", "--output", help="where (default: standard output)")
    return p


def add_identity(
    policy: Path, name: str, roles: Sequence[str], *, robots: Sequence[int] = (), shard: str = "", write: bool = True
) -> bool:
    """Adds ``[identities.NAME]`` to a policy file (made if missing); False when NAME is there already, as asked.

    With ``write`` false, only checks that the policy would take it.

    Raises:
        ConfigError: When the policy, with it, is refused.
    """
    text = policy.read_text(encoding="utf-8") if policy.exists() else HEADER.format(sim="default")
    had = parse_policy(text, str(policy)).identities.get(name)
    if had is not None:
        if (had.roles, had.robots, had.shard) != (tuple(roles), list(robots), shard):
            said = f"role {list(had.roles)}, robots {had.robots}, shard {had.shard!r}"
            raise ConfigError(
                f"{policy}: identities.{name}",
                f"{name!r} is there already ({said}), not as asked now: edit or remove its table "
                "in the policy first, or issue under another name",
            )
        return False
    role = json.dumps(roles[0]) if len(roles) == 1 else json.dumps(list(roles))
    entry = f'\n[identities."{name}"]\nrole = {role}\n'
    entry += f"robots = {json.dumps(list(robots))}\n" if robots else ""
    entry += f'shard = "{shard}"\n' if shard else ""
    parse_policy(text + entry, str(policy))  # refused before anything is written
    if write:
        policy.write_text(text + entry, encoding="utf-8")
    return True


def _issue(args: argparse.Namespace) -> None:
    try:
        robots = [int(r) for r in args.robots.split(",") if r.strip()]
    except ValueError:
        raise IwError(f"--robots takes robot ids, e.g. 1,2; got {args.robots!r}") from None
    d = Path(args.dir)
    roles = [r for r in args.role if r != "router"]
    policy = Path(args.policy) if args.policy else d / POLICY_FILE
    if roles:  # a refused entry is refused before any file is made
        add_identity(policy, args.name, roles, robots=robots, shard=args.shard, write=False)
    ident = issue(d, args.name, server="router" in args.role, hosts=tuple(args.host))
    print(f"iwz secure: {ident.cert} and {ident.key} (CN {args.name})")
    if roles:
        added = add_identity(policy, args.name, roles, robots=robots, shard=args.shard)
        print(f"iwz secure: {args.name} {'added to' if added else 'already in'} {policy}")


def _config(args: argparse.Namespace) -> None:
    load_policy(args.policy)
    net = NetConfig(mode="router", listen=tuple(args.listen), identity=args.identity, policy=args.policy)
    text = json.dumps(config_values(net), indent=2)
    if args.output:
        try:
            Path(args.output).write_text(text + "\n", encoding="utf-8")
        except OSError as e:
            raise ConfigError(
                f"-o {args.output}", f"cannot write it ({e.strerror}); give a file in a folder you may write"
            ) from None
        print(f"iwz secure: the router's configuration in {args.output}: iwz router --zenoh-config {args.output}")
    else:
        print(text)


def main(argv: Sequence[str] | None = None) -> int:
    """Runs ``iwz secure``."""
    args = _parser().parse_args(argv)
    try:
        if args.command == "init":
            ca = init_ca(args.dir, force=args.force)
            policy = Path(args.dir) / POLICY_FILE
            if not policy.exists():
                policy.write_text(HEADER.format(sim=keys.chunk(args.sim)), encoding="utf-8")
            print(f"iwz secure: authority {ca} (keep {Path(args.dir) / 'ca.key'} on this machine); policy {policy}")
        elif args.command == "issue":
            _issue(args)
        else:
            _config(args)
    except (IwError, ValueError) as e:
        print(f"iwz secure: {e}", file=sys.stderr)
        return 2
    except OSError as e:  # a file of the authority's folder that cannot be written
        where = e.filename or args.command
        print(f"iwz secure: {where}: cannot write it ({e.strerror}); check that you may write there", file=sys.stderr)
        return 2
    return 0
