#include "multibond/io/dot_writer.h"
#include <gtest/gtest.h>
TEST(X, Y) {}
