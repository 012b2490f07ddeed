/* SPDX-License-Identifier: MIT */
/* wetgraph: node-graph texture engine. Umbrella header for applications. */
#ifndef WETGRAPH_H
#define WETGRAPH_H

#include "error.h"
#include "image.h"
#include "expr.h"
#include "io.h"
#include "node.h"
#include "graph.h"
#include "eval.h"
#include "plugin.h"

#define WETGRAPH_VERSION "0.1.0"

#endif
