#!/usr/bin/env bash
# Creates what the `secure` profile needs for one deployment, in DIR:
#   ca.pem, ca.key           the deployment's own certificate authority (keep ca.key offline)
#   router.pem, router.key   the Zenoh router's certificate (its host names below)
#   <id>.pem, <id>.key       one client certificate per identity, common name <id>
#   <id>.env                 TRAFFICMESH_IDENTITY and TRAFFICMESH_ZENOH_PASSWORD of <id>
#   credentials.txt          every identity's user:password, for the router only
#   https.pem, https.key     the REST admin's HTTPS certificate (the same host names)
# Identities: the services, `observer` (telemetry subscribers, trafficmesh
# status and watch) and `runtime` (a simulation runtime: ego, external
# simulators, agents).
#
# Usage: make-certs.sh DIR [HOST...]
#   HOST: names and addresses under which the router and the admin are
#   reached (default: trafficmesh-router localhost 127.0.0.1).
# Needs openssl. Refuses to overwrite an existing DIR/ca.key.
set -euo pipefail

if [[ $# -lt 1 || $1 == -h || $1 == --help ]]; then
    sed -n '2,17p' "$0" | sed 's/^# \{0,1\}//'
    exit 2
fi
dir=$1
shift
hosts=("$@")
[[ ${#hosts[@]} -gt 0 ]] || hosts=(trafficmesh-router localhost 127.0.0.1)
identities=(stepper spawner lights crosswalks pedestrians intersection admin observer runtime)
days=825

command -v openssl >/dev/null || { echo "make-certs.sh: openssl is not installed" >&2; exit 1; }
if [[ -e $dir/ca.key ]]; then
    echo "make-certs.sh: $dir/ca.key exists; choose an empty directory" >&2
    exit 1
fi
mkdir -p "$dir"
umask 077

san=""
for h in "${hosts[@]}"; do
    if [[ $h =~ ^[0-9.]+$ || $h == *:* ]]; then san+="IP:$h,"; else san+="DNS:$h,"; fi
done
san=${san%,}

openssl req -x509 -newkey rsa:2048 -nodes -days "$days" -subj "/CN=trafficmesh-ca" \
    -keyout "$dir/ca.key" -out "$dir/ca.pem" 2>/dev/null

# sign NAME CN EXTENSIONS: NAME.key (PKCS#8) and NAME.pem signed by the CA.
sign() {
    local name=$1 cn=$2 ext=$3
    openssl req -newkey rsa:2048 -nodes -subj "/CN=$cn" \
        -keyout "$dir/$name.key" -out "$dir/$name.csr" 2>/dev/null
    printf '%s\n' "$ext" > "$dir/$name.ext"
    openssl x509 -req -in "$dir/$name.csr" -CA "$dir/ca.pem" -CAkey "$dir/ca.key" \
        -CAcreateserial -days "$days" -extfile "$dir/$name.ext" -out "$dir/$name.pem" 2>/dev/null
    rm -f "$dir/$name.csr" "$dir/$name.ext"
}

server_ext="subjectAltName=$san
extendedKeyUsage=serverAuth,clientAuth"
sign router trafficmesh-router "$server_ext"
sign https trafficmesh-admin "subjectAltName=$san
extendedKeyUsage=serverAuth"

: > "$dir/credentials.txt"
for id in "${identities[@]}"; do
    sign "$id" "$id" "extendedKeyUsage=clientAuth"
    password=$(openssl rand -hex 16)
    printf '%s:%s\n' "$id" "$password" >> "$dir/credentials.txt"
    printf 'TRAFFICMESH_IDENTITY=%s\nTRAFFICMESH_ZENOH_PASSWORD=%s\n' "$id" "$password" > "$dir/$id.env"
done
# The router authenticates with a password of its own too.
password=$(openssl rand -hex 16)
printf 'router:%s\n' "$password" >> "$dir/credentials.txt"
printf 'TRAFFICMESH_IDENTITY=router\nTRAFFICMESH_ZENOH_PASSWORD=%s\n' "$password" > "$dir/router.env"
rm -f "$dir/ca.srl"
chmod 0644 "$dir"/*.pem
echo "certificates for ${hosts[*]} in $dir: copy ca.pem, <id>.pem, <id>.key and <id>.env to the hosts that run <id>; router.* and credentials.txt to the router's"
