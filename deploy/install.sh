#!/usr/bin/env bash
# Install the Jackson host daemon as a systemd service. Run it with sudo, after `make setup`:
#
#   sudo deploy/install.sh [VENV]
#
# VENV is the virtual environment holding the `jackson` command (default: the repository's
# .venv). Idempotent: each step says what it does, or that nothing needed doing.
#   1. the system user `jackson` in the groups dialout and i2c
#   2. deploy/99-jackson.rules -> /etc/udev/rules.d/ (/dev/jackson-mcu), udev reloaded
#   3. host/config/jackson.yaml -> /etc/jackson/jackson.yaml, unless that file exists
#   4. deploy/jackson.service -> /etc/systemd/system/ with @VENV@ replaced, enabled and started
set -euo pipefail

REPO=$(cd "$(dirname "${BASH_SOURCE[0]}")/.." && pwd -P)
SERVICE_USER=jackson
RULES=/etc/udev/rules.d/99-jackson.rules
CONFIG=/etc/jackson/jackson.yaml
UNIT=/etc/systemd/system/jackson.service
DEVICE=/dev/jackson-mcu

say() { printf 'install: %s\n' "$*"; }
die() { printf 'install: %s\n' "$*" >&2; exit 1; }

[ $# -le 1 ] || die "usage: sudo $0 [VENV]"
[ "$(id -u)" -eq 0 ] || die "must run as root: sudo $0${1:+ $1}"
for tool in systemctl udevadm useradd runuser install; do
  command -v "$tool" >/dev/null 2>&1 || die "$tool not found: this needs a systemd Linux (Ubuntu 22.04 / JetPack 6)"
done

VENV=${1:-$REPO/.venv}
[ -d "$VENV" ] || die "no virtual environment at $VENV: run make setup in $REPO first (as your user, not root)"
VENV=$(cd "$VENV" && pwd -P)
[ -x "$VENV/bin/jackson" ] || die "$VENV/bin/jackson is missing: run make setup in $REPO first (as your user, not root)"
case "$VENV" in
  *[[:space:]]* | *'|'* | *'\'* | *'&'*) die "the path $VENV must not contain spaces, |, \\ or &: clone elsewhere (e.g. /opt/jackson)" ;;
esac

# ---- 1. user and groups -------------------------------------------------------------------------
for group in dialout i2c; do
  if ! getent group "$group" >/dev/null; then
    say "creating the system group $group"
    groupadd --system "$group"
  fi
done
if id -u "$SERVICE_USER" >/dev/null 2>&1; then
  for group in dialout i2c; do
    if ! id -nG "$SERVICE_USER" | tr ' ' '\n' | grep -qx "$group"; then
      say "adding user $SERVICE_USER to group $group"
      usermod -aG "$group" "$SERVICE_USER"
    fi
  done
  say "user $SERVICE_USER exists (groups: $(id -nG "$SERVICE_USER"))"
else
  say "creating the system user $SERVICE_USER (groups dialout, i2c; home /var/lib/jackson, no login)"
  useradd --system --user-group --groups dialout,i2c --home-dir /var/lib/jackson \
    --no-create-home --shell /usr/sbin/nologin "$SERVICE_USER"
fi
runuser -u "$SERVICE_USER" -- "$VENV/bin/jackson" --version >/dev/null 2>&1 \
  || die "user $SERVICE_USER cannot run $VENV/bin/jackson: the folders above $REPO must be readable by others (clone to /opt/jackson, or chmod o+rx them)"

# ---- 2. udev rule -------------------------------------------------------------------------------
if cmp -s "$REPO/deploy/99-jackson.rules" "$RULES"; then
  say "$RULES is up to date"
else
  say "installing $RULES"
  install -m 0644 "$REPO/deploy/99-jackson.rules" "$RULES"
fi
say "reloading udev rules (tty and i2c-dev devices)"
udevadm control --reload-rules || die "cannot reload the udev rules: is systemd-udevd running?"
udevadm trigger --action=change --subsystem-match=tty --subsystem-match=i2c-dev \
  || die "udevadm trigger failed: unplug and replug the ESP32-S3 instead"
udevadm settle --timeout=10 || true

# ---- 3. configuration ---------------------------------------------------------------------------
if [ -e "$CONFIG" ]; then
  say "keeping the existing $CONFIG"
else
  say "installing $CONFIG (the paper's robot; edit it for yours)"
  install -d -m 0755 "$(dirname "$CONFIG")"
  install -m 0644 "$REPO/host/config/jackson.yaml" "$CONFIG"
fi

# ---- 4. systemd unit ----------------------------------------------------------------------------
unit_text=$(sed "s|@VENV@|$VENV|g" "$REPO/deploy/jackson.service")
changed=0
if [ -e "$UNIT" ] && [ "$(cat "$UNIT")" = "$unit_text" ]; then
  say "$UNIT is up to date (ExecStart $VENV/bin/jackson)"
else
  say "installing $UNIT (ExecStart $VENV/bin/jackson)"
  printf '%s\n' "$unit_text" > "$UNIT.tmp"
  chmod 0644 "$UNIT.tmp"
  mv "$UNIT.tmp" "$UNIT"
  changed=1
fi
say "systemctl daemon-reload"
systemctl daemon-reload || die "systemctl daemon-reload failed: is systemd running?"
say "enabling jackson.service (it starts whenever $DEVICE appears)"
systemctl enable --quiet jackson.service || die "systemctl enable jackson.service failed"
if [ -e "$DEVICE" ]; then
  if [ "$changed" -eq 1 ] && systemctl is-active --quiet jackson.service; then
    say "restarting jackson.service"
    systemctl restart jackson.service || die "jackson.service did not restart: journalctl -u jackson"
  else
    say "starting jackson.service"
    systemctl start jackson.service || die "jackson.service did not start: journalctl -u jackson"
  fi
else
  say "$DEVICE is not there yet: plug the ESP32-S3 in by its USB port and the daemon starts"
fi
say "done; check it with: systemctl status jackson   and   journalctl -u jackson -f"
