#!/usr/bin/env bash
# `make data`: fetches the third-party example data that may not be redistributed
# with geosynth (Paul Merrell's lattices, the WaveFunctionCollapse samples and
# tile sets, the Stanford meshes, the Embark textures, ephtracy's voxel models)
# into the data root, the folder configs name as ${data}/...
#
# usage: scripts/fetch-data.sh [ITEM ...]     fetch everything, or only these items
#        scripts/fetch-data.sh --list         the manifest's files (destination, bytes, origin)
#        scripts/fetch-data.sh --has PATH     exit 0 when PATH (under the data root) is in the manifest
# ITEM: a file or folder under the data root as the manifest names it, e.g.
#   meshes/armadillo.obj   or   model-synthesis/merrell42-model-synthesis   or   wfc
#
# Each file of the manifest (scripts/data-manifest.tsv: destination, sha256, bytes,
# upstream repository, full commit, path) is downloaded with curl from
# https://raw.githubusercontent.com/REPOSITORY/COMMIT/PATH, its sha256 checked, and
# only then renamed into place (a temporary file in the same folder), so an
# interrupted or corrupted download never leaves a bad file under its real name.
# A file already present with the right checksum is left alone (running again is
# cheap); one with a wrong checksum is replaced.
#
# env: GS_DATA         the data root (default: this repository's data/); relative to
#                      the current directory, as for geosynth itself
#      GS_DATA_MIRROR  a folder laid out like the data root: copy from there instead
#                      of downloading (checksums still checked), e.g. for machines
#                      without access to GitHub
#      GS_DATA_MANIFEST another manifest (the tests use a small one)
# Exit: 0 every selected file present and verified; 1 some file could not be
# fetched or failed its checksum (each one named); 2 usage (unknown item or option).
set -uo pipefail
here=$(cd "$(dirname "$0")/.." && pwd)
manifest=${GS_DATA_MANIFEST:-$here/scripts/data-manifest.tsv}
root=${GS_DATA:-$here/data}
[[ $root == /* ]] || root=$PWD/$root
mirror=${GS_DATA_MIRROR:-}
[[ -z $mirror || $mirror == /* ]] || mirror=$PWD/$mirror

die() { echo "fetch-data: $*" >&2; exit 2; }
[[ -r $manifest ]] || die "cannot read the manifest $manifest"

# The manifest's rows: dest sha bytes repo commit path (tab-separated, '#' comments).
dests=() shas=() sizes=() repos=() commits=() paths=()
while IFS=$'\t' read -r d s b r c p; do
  [[ -z $d || $d == \#* ]] && continue
  [[ $s =~ ^[0-9a-f]{64}$ && $c =~ ^[0-9a-f]{40}$ && -n $p ]] \
    || die "$manifest: bad row for '$d' (expected destination, sha256, bytes, repository, 40-hex commit, path)"
  dests+=("$d") shas+=("$s") sizes+=("$b") repos+=("$r") commits+=("$c") paths+=("$p")
done <"$manifest"

case ${1:-} in
  -h|--help) sed -n '2,/^set -uo/p' "$0" | sed '$d; s/^# \{0,1\}//'; exit 0 ;;
  --list)
    for i in "${!dests[@]}"; do
      printf '%s\t%s bytes\t%s@%s:%s\n' "${dests[i]}" "${sizes[i]}" "${repos[i]}" "${commits[i]}" "${paths[i]}"
    done
    exit 0 ;;
  --has)
    [[ $# -eq 2 ]] || die "--has needs one path"
    want=${2#./}
    for d in "${dests[@]}"; do [[ $d == "$want" ]] && exit 0; done
    exit 1 ;;
  -*) die "unknown option '$1' (see --help)" ;;
esac

# Which rows: all, or those equal to or under an ITEM.
selected=()
for item in "$@"; do
  item=${item%/}; item=${item#./}
  found=0
  for i in "${!dests[@]}"; do
    if [[ ${dests[i]} == "$item" || ${dests[i]} == "$item"/* ]]; then selected+=("$i"); found=1; fi
  done
  [[ $found -eq 1 ]] || die "'$item' is not in the manifest (scripts/fetch-data.sh --list shows what it fetches)"
done
[[ $# -eq 0 ]] && selected=("${!dests[@]}")

urlencode() { # the path part of a URL: everything but unreserved characters and '/'
  local s=$1 out="" c i
  for ((i = 0; i < ${#s}; i++)); do
    c=${s:i:1}
    case $c in [A-Za-z0-9._~/-]) out+=$c ;; *) out+=$(printf '%%%02X' "'$c") ;; esac
  done
  printf '%s' "$out"
}

if [[ -z $mirror ]] && ! command -v curl >/dev/null; then
  die "curl is needed to download (apt-get install curl), or set GS_DATA_MIRROR to a local copy"
fi

tmp=""
trap '[[ -n $tmp ]] && rm -f -- "$tmp"; exit 130' INT TERM

present=0 fetched=0 failed=0
declare -A seen=()
for i in "${selected[@]}"; do
  [[ -n ${seen[$i]:-} ]] && continue
  seen[$i]=1
  dest=${dests[i]} want=${shas[i]}
  target=$root/$dest
  if [[ -f $target ]] && [[ $(sha256sum <"$target" | cut -d' ' -f1) == "$want" ]]; then
    present=$((present + 1))
    continue
  fi
  [[ -e $target ]] && echo "fetch-data: $dest: present but its checksum differs: replacing it"
  dir=$(dirname -- "$target")
  if ! mkdir -p -- "$dir"; then
    echo "fetch-data: FAILED $dest: cannot create $dir" >&2; failed=$((failed + 1)); continue
  fi
  tmp=$dir/.$(basename -- "$target").fetch-$$
  if [[ -n $mirror ]]; then
    from=$mirror/$dest
    if [[ ! -f $from ]]; then
      echo "fetch-data: FAILED $dest: not in the mirror $mirror" >&2
      failed=$((failed + 1)); tmp=""; continue
    fi
    cp -- "$from" "$tmp" || { echo "fetch-data: FAILED $dest: cannot copy $from" >&2; rm -f -- "$tmp"; tmp=""; failed=$((failed + 1)); continue; }
  else
    from="https://raw.githubusercontent.com/${repos[i]}/${commits[i]}/$(urlencode "${paths[i]}")"
    if ! curl -fsSL --retry 3 --connect-timeout 20 -o "$tmp" -- "$from"; then
      echo "fetch-data: FAILED $dest: download of $from failed" >&2
      rm -f -- "$tmp"; tmp=""; failed=$((failed + 1)); continue
    fi
  fi
  got=$(sha256sum <"$tmp" | cut -d' ' -f1)
  if [[ $got != "$want" ]]; then
    echo "fetch-data: FAILED $dest: checksum mismatch for $from: sha256 $got, expected $want" >&2
    rm -f -- "$tmp"; tmp=""; failed=$((failed + 1)); continue
  fi
  mv -f -- "$tmp" "$target" || { echo "fetch-data: FAILED $dest: cannot rename into place" >&2; rm -f -- "$tmp"; tmp=""; failed=$((failed + 1)); continue; }
  tmp=""
  fetched=$((fetched + 1))
  echo "fetch-data: $dest (${sizes[i]} bytes) from $from"
done

echo "fetch-data: ${#seen[@]} files: $fetched fetched, $present present already, $failed failed (data root $root)"
[[ $failed -eq 0 ]]
