# Sourced by make_samples.sh and make_corpus.sh: find_cura_resources prints the folder that
# holds Cura's printer definitions (definitions/, extruders/), looked for in $CURA_RESOURCES,
# /usr/share/cura/resources, then a cache; if none exists it unpacks only those folders of
# Debian's 'cura' package (apt-get download, no install, no root) into the cache.
# Needs $WORK, a scratch folder.
find_cura_resources() {
    local cache="${XDG_CACHE_HOME:-$HOME/.cache}/gcode-opt-cura-resources"
    for d in "${CURA_RESOURCES:-}" /usr/share/cura/resources "$cache/usr/share/cura/resources"; do
        if [ -n "$d" ] && [ -f "$d/definitions/fdmprinter.def.json" ]; then
            echo "$d"; return 0
        fi
    done
    echo "Cura definitions not found; fetching them from the Debian 'cura' package" >&2
    mkdir -p "$cache"
    (cd "$WORK" && apt-get download cura >&2)
    dpkg-deb --fsys-tarfile "$WORK"/cura_*.deb |
        tar -x -C "$cache" ./usr/share/cura/resources/definitions ./usr/share/cura/resources/extruders
    echo "$cache/usr/share/cura/resources"
}
