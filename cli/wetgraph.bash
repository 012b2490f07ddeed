# SPDX-License-Identifier: MIT
# Bash completion for wetgraph. Everything comes from wetgraph itself, so it follows the
# program it completes: the commands from `wetgraph --help`, each command's options (and which
# take a value) from `wetgraph COMMAND --help`, graph names from `wetgraph graphs --paths`,
# node types from `wetgraph nodes`, and the parameters, inputs and outputs of the graph on the
# command line from `wetgraph info` (after --set, --input and --output). Installed by meson
# into bash-completion's folder; to try it from the source tree: source cli/wetgraph.bash.

# the lines of `wetgraph ARGS...` whose first word is taken (a table's first column)
_wetgraph_column()
{
    "${_wetgraph_cmd:-wetgraph}" "$@" 2>/dev/null | awk 'NF { print $1 }'
}

# the options of a command, "--name" or "--name ARG" per line, from its --help
_wetgraph_options()
{
    "${_wetgraph_cmd:-wetgraph}" "$1" --help 2>/dev/null |
        sed -n 's/^ \{1,\}\(-[a-zA-Z], \)\{0,1\}\(--[a-z0-9=-]*\)\( [A-Z][A-Za-z0-9.|_=-]*\)\{0,1\}.*/\2\3/p'
}

# the names in one block of `wetgraph info GRAPH` (parameters:, inputs: or outputs:)
_wetgraph_info_block()
{
    "${_wetgraph_cmd:-wetgraph}" info "$1" 2>/dev/null |
        awk -v block="$2:" '/^[a-z]+:$/ { on = ($0 == block); next } on && /^  [^ ]/ { print $1 }'
}

_wetgraph()
{
    local _wetgraph_cmd=${COMP_WORDS[0]}
    local cur=${COMP_WORDS[COMP_CWORD]} prev=${COMP_WORDS[COMP_CWORD - 1]}
    COMPREPLY=()
    if ((COMP_CWORD == 1)); then
        local cmds
        cmds=$("$_wetgraph_cmd" --help 2>/dev/null |
            awk '/^commands:/ { on = 1; next } on && /^  [a-z]/ { print $1 } on && /^$/ { on = 0 }')
        mapfile -t COMPREPLY < <(compgen -W "$cmds" -- "$cur")
        return
    fi
    local sub=${COMP_WORDS[1]}
    # options taking a value, and the graph: the first word that is neither an option nor one
    # of their values (bash splits NAME=VALUE at '=' into NAME, =, VALUE)
    local opts with_value=" " graph="" i w
    # every command takes --plugin LIB (the overview's "Node plugins")
    opts=$(_wetgraph_options "$sub")$'\n'"--plugin LIB"
    while read -r w rest; do
        [[ -n $rest ]] && with_value+="$w "
        [[ -n $rest && $w == --out ]] && with_value+="-o "
    done <<<"$opts"
    for ((i = 2; i < COMP_CWORD; i++)); do
        w=${COMP_WORDS[i]}
        if [[ $w == -* ]]; then
            [[ $with_value == *" $w "* ]] && ((i++))
            [[ ${COMP_WORDS[i + 1]:-} == "=" ]] && ((i += 2))
        elif [[ -z $graph && $w != "=" ]]; then
            graph=$w
        fi
    done
    # NAME=VALUE after --set or --input: the value (files for --input)
    if [[ $prev == "=" && COMP_CWORD -ge 3 ]]; then
        if [[ ${COMP_WORDS[COMP_CWORD - 3]} == --input ]]; then
            mapfile -t COMPREPLY < <(compgen -f -- "$cur")
        fi
        return
    fi
    if [[ $cur == "=" ]]; then
        [[ ${COMP_WORDS[COMP_CWORD - 2]} == --input ]] && mapfile -t COMPREPLY < <(compgen -f)
        return
    fi
    case $prev in
    --set | --input)
        [[ -n $graph ]] || return
        local block=parameters
        [[ $prev == --input ]] && block=inputs
        mapfile -t COMPREPLY < <(compgen -S = -W "$(_wetgraph_info_block "$graph" $block)" -- "$cur")
        compopt -o nospace 2>/dev/null
        return
        ;;
    --output)
        [[ -n $graph ]] &&
            mapfile -t COMPREPLY < <(compgen -W "$(_wetgraph_info_block "$graph" outputs)" -- "$cur")
        return
        ;;
    --format)
        mapfile -t COMPREPLY < <(compgen -W "png png16 tif16 exr exr32" -- "$cur")
        return
        ;;
    --png-compression)
        mapfile -t COMPREPLY < <(compgen -W "fast deflate none" -- "$cur")
        return
        ;;
    --plugin)
        mapfile -t COMPREPLY < <(compgen -d -- "$cur"; compgen -f -X '!*.so' -- "$cur")
        return
        ;;
    -o | --out | --cache)
        mapfile -t COMPREPLY < <(compgen -d -- "$cur")
        return
        ;;
    esac
    if [[ $with_value == *" $prev "* ]]; then
        mapfile -t COMPREPLY < <(compgen -f -- "$cur")
        return
    fi
    if [[ $cur == -* ]]; then
        mapfile -t COMPREPLY < <(compgen -W "$(awk '{ print $1 }' <<<"$opts")" -- "$cur")
        return
    fi
    case $sub in
    nodes)
        mapfile -t COMPREPLY < <(compgen -W "$(_wetgraph_column nodes)" -- "$cur")
        ;;
    render | watch | check | info | dot)
        if [[ -z $graph || $sub == check ]]; then
            # graph files, folders to reach them, and the graphs found by name
            mapfile -t COMPREPLY < <(
                compgen -W "$(_wetgraph_column graphs --paths)" -- "$cur"
                compgen -d -- "$cur"
                compgen -f -X '!*.wetgraph' -- "$cur"
            )
        fi
        ;;
    esac
}
complete -F _wetgraph wetgraph
