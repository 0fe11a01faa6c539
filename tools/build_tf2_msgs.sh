#!/usr/bin/env bash
# placeholder, replaced by the tf2_msgs build (in progress)
exit 0
