#!/usr/bin/python3
"""TLS end to end: a real meshsmoothd serving a certificate signed by a CA made here (openssl),
the CLI connecting with --tls-ca.

- the CA's file: the job runs and the output mesh has the input's counts;
- another CA's file: exit 3, the message names the failed certificate check and says the
  certificate is not signed by a CA of --tls-ca;
- no --tls-ca against the TLS server: exit 3 with the hint to use --tls-ca;
- --tls-ca against a plaintext server: exit 3 with the hint to leave it out.

Run by ctest: tls_test.py --cli build/client/meshsmooth --server build/server/meshsmoothd
Prints one line per check and ends with 'N passed, M failed'.
"""
import os
import sys

from harness import Server, parser, ply_counts, require, run, run_checks

# builtin:noisy-sphere (core/shapes): an icosphere of level 4.
VERTICES, FACES = 2562, 5120


def openssl(*args):
    r = run(["openssl", *args])
    require(r.returncode == 0, f"openssl {args[0]} failed ({r.returncode}): {r.stderr.strip()}")


def make_ca(tmp, name):
    """A self-signed CA certificate and its key: (cert, key) paths."""
    cert, key = os.path.join(tmp, f"{name}.pem"), os.path.join(tmp, f"{name}.key")
    openssl("req", "-x509", "-newkey", "rsa:2048", "-nodes", "-days", "1", "-subj", f"/CN=meshsmooth test {name}",
            "-addext", "basicConstraints=critical,CA:TRUE", "-addext", "keyUsage=critical,keyCertSign,cRLSign",
            "-keyout", key, "-out", cert)
    return cert, key


def make_server_cert(tmp, ca_cert, ca_key):
    """A server certificate for 127.0.0.1 and localhost signed by the CA: (cert, key) paths."""
    cert, key, csr = (os.path.join(tmp, f"server.{ext}") for ext in ("pem", "key", "csr"))
    ext = os.path.join(tmp, "server.ext")
    with open(ext, "w") as f:
        f.write("subjectAltName=IP:127.0.0.1,DNS:localhost\nbasicConstraints=CA:FALSE\n"
                "keyUsage=critical,digitalSignature,keyEncipherment\nextendedKeyUsage=serverAuth\n")
    openssl("req", "-newkey", "rsa:2048", "-nodes", "-subj", "/CN=localhost", "-keyout", key, "-out", csr)
    openssl("x509", "-req", "-in", csr, "-CA", ca_cert, "-CAkey", ca_key, "-CAcreateserial", "-days", "1",
            "-extfile", ext, "-out", cert)
    return cert, key


def main():
    a = parser(__doc__, required=("cli", "server")).parse_args()
    return run_checks(lambda checks, tmp: tls_checks(a, checks.check, tmp), tmp_prefix="meshsmooth-tls-")


def tls_checks(a, check, tmp):
    cli = a.cli

    def certificates():
        ca = make_ca(tmp, "ca")
        other_ca = make_ca(tmp, "other-ca")
        server = make_server_cert(tmp, *ca)
        # The chain as a TLS client checks it, before meshsmoothd sees it.
        r = run(["openssl", "verify", "-CAfile", ca[0], server[0]])
        require(r.returncode == 0, f"openssl verify: {r.stdout} {r.stderr}")
        return ca[0], other_ca[0], server
    made = check("a CA, another CA and a server certificate the first signed (openssl)", certificates)
    if made is None:
        return
    ca, other_ca, (cert, key) = made

    def smooth(name, server, *flags):
        out = os.path.join(tmp, f"{name}.ply")
        r = run([cli, "smooth", "builtin:noisy-sphere", "-o", out, "--iterations", "3", "--server", server,
                 "--timeout", "30", *flags])
        return r, out

    with Server(a.server, "--quiet", "--tls-cert", cert, "--tls-key", key) as tls:
        def with_the_ca():
            r, out = smooth("tls", tls.address, "--tls-ca", ca)
            require(r.returncode == 0, f"exit {r.returncode}: {r.stderr}")
            require(os.path.isfile(out), f"no output {out}")
            require(ply_counts(out) == (VERTICES, FACES), f"the output has {ply_counts(out)}, not {(VERTICES, FACES)}")
        check(f"--tls-ca with the CA: the job runs over TLS, the output has {VERTICES} vertices", with_the_ca)

        def with_another_ca():
            r, out = smooth("wrong-ca", tls.address, "--tls-ca", other_ca, "--retries", "0")
            require(r.returncode == 3, f"exit {r.returncode}: {r.stderr}")
            require("certificate verify failed" in r.stderr, r.stderr)
            require("not signed by a CA in --tls-ca" in r.stderr, r.stderr)
            require("leave out --tls-ca" not in r.stderr, f"the hint blames a plaintext server: {r.stderr}")
            require(not os.path.exists(out), f"{out} written")
        check("--tls-ca with another CA: exit 3, the certificate check named, not signed by that CA",
              with_another_ca)

        def plaintext():
            r, out = smooth("plaintext", tls.address, "--retries", "0")
            require(r.returncode == 3, f"exit {r.returncode}: {r.stderr}")
            require("UNAVAILABLE" in r.stderr and "the server may require TLS: --tls-ca FILE" in r.stderr, r.stderr)
            require(not os.path.exists(out), f"{out} written")
        check("no --tls-ca against the TLS server: exit 3, the hint to use --tls-ca", plaintext)

    with Server(a.server, "--quiet") as plain:
        def tls_against_plaintext():
            r, out = smooth("tls-plain", plain.address, "--tls-ca", ca, "--retries", "0")
            require(r.returncode == 3, f"exit {r.returncode}: {r.stderr}")
            require("the server may not use TLS: leave out --tls-ca" in r.stderr, r.stderr)
            require(not os.path.exists(out), f"{out} written")
        check("--tls-ca against a plaintext server: exit 3, the hint to leave it out", tls_against_plaintext)


if __name__ == "__main__":
    sys.exit(main())
