"""A real mosquitto broker for tests, on 127.0.0.1 at a free port with its
own configuration file (persistence off unless asked), and a paho-mqtt subscriber that
collects what arrives."""

import os
import pwd
import shutil
import signal
import socket
import subprocess
import threading
import time

import pytest

from gstlandmark.devtools.fleetbench import start_mosquitto, stop_mosquitto

MOSQUITTO = shutil.which("mosquitto") or (
    "/usr/sbin/mosquitto" if os.access("/usr/sbin/mosquitto", os.X_OK)
    else None)
MOSQUITTO_PASSWD = shutil.which("mosquitto_passwd")

needs_mosquitto = pytest.mark.skipif(
    MOSQUITTO is None or MOSQUITTO_PASSWD is None,
    reason="the mosquitto broker is not installed (scripts/test.sh "
    "installs it)")


def free_port():
    with socket.socket() as s:
        s.bind(("127.0.0.1", 0))
        return s.getsockname()[1]


class Broker:
    """mosquitto -c CONF. users: {name: password}; anonymous clients are
    allowed only when there are none."""

    def __init__(self, directory, users=None, tls=None, persistence=False):
        self.dir = str(directory)
        self.persistence = persistence   # sessions kept across restarts
        self.tls = tls          # (CA, certificate, key) files: TLS only
        self.port = free_port()
        self.users = dict(users or {})
        self.proc = None
        self.conf = os.path.join(self.dir, "mosquitto.conf")
        self.passwords = os.path.join(self.dir, "passwords")
        self.log = os.path.join(self.dir, "mosquitto.log")

    def _write_config(self):
        # run as ourselves: as root mosquitto would switch to its own user,
        # who cannot read the test's private directory
        lines = [f"user {pwd.getpwuid(os.getuid()).pw_name}",
                 f"listener {self.port} 127.0.0.1",
                 f"persistence {'true' if self.persistence else 'false'}",
                 f"persistence_location {self.dir}/",
                 f"log_dest file {self.log}", "log_type all"]
        if self.tls:
            ca, cert, key = self.tls
            lines += [f"cafile {ca}", f"certfile {cert}", f"keyfile {key}"]
        if self.users:
            self.write_passwords(self.users)
            lines += ["allow_anonymous false",
                      f"password_file {self.passwords}"]
        else:
            lines += ["allow_anonymous true"]
        with open(self.conf, "w") as f:
            f.write("\n".join(lines) + "\n")

    def write_passwords(self, users):
        """Replaces the password file (the broker reads it again on
        reload())."""
        if os.path.exists(self.passwords):
            os.remove(self.passwords)
        for i, (name, password) in enumerate(users.items()):
            args = [MOSQUITTO_PASSWD, "-b"]
            if i == 0:
                args.append("-c")
            subprocess.run(args + [self.passwords, name, password],
                           check=True, capture_output=True, timeout=10)
        os.chmod(self.passwords, 0o600)

    def start(self, timeout_s=5.0):
        self._write_config()
        self.proc = start_mosquitto([MOSQUITTO, "-c", self.conf], self.port,
                                    timeout_s)
        return self

    def reload(self):
        self.proc.send_signal(signal.SIGHUP)

    def stop(self):
        stop_mosquitto(self.proc)
        self.proc = None


class Subscriber:
    """Subscribes (QoS 1) and keeps (topic, payload bytes, retain) in
    arrival order."""

    def __init__(self, broker, topic="landmark/#", username=None,
                 password=None, name="test-subscriber", ca=None):
        import paho.mqtt.client as mqtt
        self.messages = []
        self.lock = threading.Lock()
        self.subscribed = threading.Event()
        self.client = mqtt.Client(mqtt.CallbackAPIVersion.VERSION2,
                                  client_id=f"{name}-{os.getpid()}",
                                  protocol=mqtt.MQTTv311)
        if username:
            self.client.username_pw_set(username, password)
        if ca:
            self.client.tls_set(ca_certs=ca)
        self.client.on_message = self._on_message
        self.client.on_subscribe = lambda *a: self.subscribed.set()
        self.client.connect("127.0.0.1", broker.port, keepalive=30)
        self.client.loop_start()
        self.client.subscribe(topic, qos=1)
        if not self.subscribed.wait(5):
            self.close()
            raise RuntimeError("no SUBACK from the broker")

    def _on_message(self, client, userdata, msg):
        with self.lock:
            self.messages.append((msg.topic, bytes(msg.payload), msg.retain))

    def take(self):
        with self.lock:
            return list(self.messages)

    def close(self):
        self.client.disconnect()
        self.client.loop_stop()


def make_certificates(directory, name):
    """A certificate authority NAME-ca.pem and a broker certificate for
    127.0.0.1 signed by it (NAME-server.pem, NAME-server.key), with
    openssl, EC keys (fast). Returns (ca, cert, key) paths."""
    d = str(directory)
    ca_key, ca = f"{d}/{name}-ca.key", f"{d}/{name}-ca.pem"
    key, csr = f"{d}/{name}-server.key", f"{d}/{name}-server.csr"
    cert, ext = f"{d}/{name}-server.pem", f"{d}/{name}-ext.cnf"
    ec = ["-newkey", "ec", "-pkeyopt", "ec_paramgen_curve:prime256v1",
          "-nodes"]

    def run(*args):
        subprocess.run(["openssl", *args], check=True, capture_output=True,
                       timeout=30)
    run("req", "-x509", *ec, "-keyout", ca_key, "-out", ca, "-days", "2",
        "-subj", f"/CN={name} test authority")
    run("req", *ec, "-keyout", key, "-out", csr, "-subj", "/CN=127.0.0.1")
    with open(ext, "w") as f:
        f.write("subjectAltName=IP:127.0.0.1\n")
    run("x509", "-req", "-in", csr, "-CA", ca, "-CAkey", ca_key,
        "-CAcreateserial", "-out", cert, "-days", "2", "-extfile", ext)
    return ca, cert, key


def wait_for(predicate, timeout_s, step_s=0.05):
    deadline = time.monotonic() + timeout_s
    while time.monotonic() < deadline:
        if predicate():
            return True
        time.sleep(step_s)
    return predicate()
