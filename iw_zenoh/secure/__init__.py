"""Security: identities (a certificate per process), the policy, the router's rules (docs/security.md)."""

from __future__ import annotations

__all__: list[str] = []
