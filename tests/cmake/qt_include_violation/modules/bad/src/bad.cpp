#include <QString>
int badFunction() {
  return 1;
}
